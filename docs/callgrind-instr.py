#!/usr/bin/env python3
"""Per-instruction instruction counts of one function from a callgrind profile, beside the
function's disassembly: what `callgrind_annotate` cannot show for a traversal loop inlined into
one body. The profile must be recorded with `valgrind --tool=callgrind --dump-instr=yes`.

Usage: callgrind-instr.py CALLGRIND_OUT BINARY 'FULL::FUNCTION::NAME' > listing.txt

Each line of the listing is `count  address: instruction`. An instruction executed once per ray
has the ray count, one per triangle test the test count, and so on, so
`awk 'NR>1{c[$1]+=$1; n[$1]++} END{for(k in c) print k, n[k], c[k]}' listing.txt | sort -k3 -n`
groups the function's instructions by how often they ran (count, instructions, total)."""
import collections
import re
import subprocess
import sys

profile, binary, wanted = sys.argv[1:4]
counts = collections.Counter()
names = {}
inside = after_calls = False
address = 0
for line in open(profile):
    m = re.match(r"^(c?fn)=\((\d+)\)(?: (.*))?$", line.rstrip("\n"))
    if m:
        kind, index, name = m.groups()
        if name:
            names[index] = name
        if kind == "fn":
            inside = names.get(index) == wanted
        continue
    if line.startswith("calls="):
        after_calls = True
        continue
    m = re.match(r"^(0x[0-9a-f]+|[+-]\d+|\*)\s+\S+\s+(\d+)$", line.strip())
    if m:
        a = m.group(1)
        if a.startswith("0x"):
            address = int(a, 16)
        elif a != "*":
            address += int(a)
        if after_calls:
            # The line after `calls=` is the call's inclusive cost, not this function's own.
            after_calls = False
            continue
        if inside:
            counts[address] += int(m.group(2))
if not counts:
    sys.exit(f"no instructions of {wanted!r} in {profile}")
low, high = min(counts), max(counts)
listing = subprocess.run(
    ["objdump", "-d", "--no-show-raw-insn", "-C", f"--start-address={low:#x}", f"--stop-address={high + 16:#x}", binary],
    capture_output=True, text=True, check=True,
).stdout
print("total", sum(counts.values()))
for line in listing.splitlines():
    m = re.match(r"^\s*([0-9a-f]+):\s*(.*)$", line)
    if m:
        print(f"{counts.get(int(m.group(1), 16), 0):>11}  {line.strip()}")
