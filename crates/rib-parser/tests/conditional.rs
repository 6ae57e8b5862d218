//! Conditional RIB (`IfBegin`/`ElseIf`/`Else`/`IfEnd`) and `Resource`: every operator of the
//! expression language, variables from options, attributes and the frame, errors located in
//! the expression, and the corpus files that use them.

use rib_parser::conditional::{Value, Variables, evaluate};
use rib_parser::scene::Shape;
use rib_parser::{LoadOptions, load_bytes};
use std::collections::HashMap;

struct Vars(HashMap<&'static str, Value>);

impl Variables for Vars {
    fn lookup(&self, name: &str) -> Option<Value> {
        self.0.get(name).cloned()
    }
}

fn vars() -> Vars {
    Vars(HashMap::from([
        ("Frame", Value::Number(3.0)),
        ("user:pass", Value::Str("shadow".into())),
        ("Option:user:quality", Value::Number(2.0)),
        ("table", Value::Str("user".into())),
        ("which", Value::Str("pass".into())),
    ]))
}

fn eval(expr: &str) -> bool {
    evaluate(expr, &vars()).unwrap_or_else(|e| panic!("{expr}: {e:?}"))
}

fn eval_err(expr: &str) -> (usize, String) {
    match evaluate(expr, &vars()) {
        Ok(v) => panic!("{expr} evaluated to {v} instead of failing"),
        Err(e) => (e.offset, e.message),
    }
}

#[test]
fn comparisons_numeric_and_string() {
    assert!(eval("$Frame == 3"));
    assert!(!eval("$Frame != 3"));
    assert!(eval("$Frame < 4") && eval("$Frame <= 3") && eval("$Frame > 2") && eval("$Frame >= 3"));
    assert!(!eval("$Frame < 3") && !eval("$Frame > 3"));
    // A number against a string that reads as one compares numerically.
    assert!(eval("29 == '29.0'"));
    // Two strings compare as strings.
    assert!(!eval("'29' == '29.0'"));
    assert!(eval("'abc' < 'abd'"));
    assert!(eval("$user:pass == 'shadow'") && eval("$user:pass != 'beauty'"));
}

#[test]
fn logic_short_circuits_and_groups() {
    assert!(eval("true && !false"));
    assert!(eval("false || true"));
    assert!(!eval("!(true || false)"));
    assert!(eval("(1 == 2 || 2 == 2) && 3 == 3"));
    // && binds tighter than ||.
    assert!(eval("true || false && false"));
    assert!(!eval("(true || false) && false"));
    // The right side is not evaluated when the left decides: the undefined variable is fine.
    assert!(eval("true || $nowhere == 1"));
    assert!(!eval("false && $nowhere == 1"));
}

#[test]
fn arithmetic_and_precedence() {
    assert!(eval("1 + 4 * 7.0 == '29'"));
    assert!(eval("(1 + 4) * 7 == 35"));
    assert!(eval("10 / 4 == 2.5") && eval("7 - 2 - 1 == 4") && eval("-$Frame == -3"));
    assert!(eval("2e1 == 20") && eval(".5 * 4 == 2"));
}

#[test]
fn regex_matching() {
    assert!(eval("$user:pass =~ '^sha'"));
    assert!(!eval("$user:pass =~ '^dow'"));
    assert!(eval("'value' =~ 'val'"));
    // RiCPP's test: an escaped quote on the left, an escaped '*' in the pattern.
    assert!(eval(r"'*abc\'' =~ '\*abc?'"));
}

#[test]
fn concat_defined_and_references() {
    assert!(eval("concat('sha', 'dow') == $user:pass"));
    assert!(eval("concat($Frame, '-', 1) == '3-1'"));
    assert!(eval("defined(user:pass) && !defined(user:nothing)"));
    assert!(eval("defined($Frame)"));
    // References expand inside strings and inside braces, nested.
    assert!(eval("'$user:pass' == 'shadow'"));
    assert!(eval("'${user:pass}-${Frame}' == 'shadow-3'"));
    assert!(eval("${${table}:${which}} == 'shadow'"));
    assert!(eval("'${$table:$which}' == 'shadow'"));
    assert!(eval("$(Frame) == 3"));
    assert!(eval(r"'\$Frame' == concat('$', 'Frame')"));
    // Truth of plain values.
    assert!(eval("$Frame") && !eval("0") && eval("'x'") && !eval("''"));
}

#[test]
fn malformed_expressions_are_located_errors() {
    let cases: &[(&str, usize, &str)] = &[
        ("$Frame = 3", 7, "'=' is not an operator"),
        ("$Frame == ", 10, "ends where a value was expected"),
        ("'open", 0, "no closing '"),
        ("(1 == 1", 7, "expected ')'"),
        ("1 == 1)", 6, "unexpected ')'"),
        ("pass == 1", 0, "unknown name 'pass'"),
        ("$nowhere == 1", 0, "$nowhere is not defined"),
        ("'a' =~ '('", 4, "is not a regular expression"),
        ("1 / 0", 2, "division by zero"),
        ("'a' + 1", 4, "'+' needs numbers"),
        ("1 & 1", 2, "use '&&'"),
        ("$", 0, "followed by a variable name"),
        ("${Frame", 0, "no closing '}'"),
        ("defined(1)", 8, "defined() takes a variable name"),
        ("", 0, "ends where a value was expected"),
        ("1 @ 2", 2, "unexpected character '@'"),
    ];
    for (expr, offset, message) in cases {
        let (at, got) = eval_err(expr);
        assert!(got.contains(message), "{expr}: {got}");
        assert_eq!(at, *offset, "{expr}: {got}");
    }
}

#[test]
fn hostile_expressions_fail_without_panic() {
    let deep = format!("{}1{}", "(".repeat(100_000), ")".repeat(100_000));
    assert!(eval_err(&deep).1.contains("nested more than"));
    let nots = format!("{}true", "!".repeat(100_000));
    assert!(eval_err(&nots).1.contains("nested more than"));
    let refs = format!("{}Frame{}", "${".repeat(1000), "}".repeat(1000));
    assert!(evaluate(&refs, &vars()).is_err());
    // A pattern whose compiled form is huge is refused, not built.
    assert!(eval_err("'a' =~ '(a{1000}){1000}'").1.contains("not a regular expression"));
}

fn load(rib: &str) -> rib_parser::Loaded {
    load_bytes("test.rib", rib.as_bytes().to_vec(), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
}

fn load_err(rib: &str) -> String {
    match load_bytes("test.rib", rib.as_bytes().to_vec(), &LoadOptions::default()) {
        Ok(_) => panic!("expected an error for:\n{rib}"),
        Err(e) => e.render(),
    }
}

fn radii(loaded: &rib_parser::Loaded) -> Vec<f32> {
    loaded
        .scene
        .shapes
        .iter()
        .filter_map(|s| match *s.shape {
            Shape::Sphere { radius, .. } => Some(radius),
            _ => None,
        })
        .collect()
}

#[test]
fn only_the_active_branch_builds() {
    let rib = r#"
Option "user" "string pass" ["beauty"]
FrameBegin 2
WorldBegin
Attribute "user" "float level" [3]
IfBegin "$user:pass == 'shadow'"
  Sphere 1 -1 1 360
ElseIf "$Frame == 2 && $level > 2"
  Sphere 2 -2 2 360
  IfBegin "$Attribute:user:level == 99"
    Sphere 20 -20 20 360
  Else
    Sphere 21 -21 21 360
  IfEnd
ElseIf "true"
  Sphere 3 -3 3 360
Else
  Sphere 4 -4 4 360
IfEnd
IfBegin "$Option:user:pass =~ '^bea'"
  Sphere 5 -5 5 360
IfEnd
IfBegin "false"
  IfBegin "this is not evaluated"
    Sphere 6 -6 6 360
  Else
    Sphere 7 -7 7 360
  IfEnd
  ReadArchive "missing.rib"
Else
  Sphere 8 -8 8 360
IfEnd
WorldEnd
FrameEnd
"#;
    let loaded = load(rib);
    assert_eq!(radii(&loaded), vec![2.0, 21.0, 5.0, 8.0]);
    assert!(
        !loaded.diagnostics.render(&loaded.sources).contains("IfBegin"),
        "{}",
        loaded.diagnostics.render(&loaded.sources)
    );
}

#[test]
fn a_malformed_expression_is_an_error_at_its_column() {
    let rib = "WorldBegin\nIfBegin \"$Frame = 1\"\nSphere 1 -1 1 360\nIfEnd\nWorldEnd\n";
    let err = load_err(rib);
    // Line 2, the '=' at byte 7 of the expression, which starts at column 10.
    assert!(err.contains("test.rib:2:17: error:"), "{err}");
    assert!(err.contains("'=' is not an operator"), "{err}");
}

#[test]
fn nesting_beyond_the_limit_is_fatal() {
    let mut options = LoadOptions::default();
    options.read.limits.max_nesting_depth = 50;
    let rib = format!("WorldBegin\n{}WorldEnd\n", "IfBegin \"true\"\n".repeat(60));
    let err = load_bytes("test.rib", rib.into_bytes(), &options).unwrap_err().render();
    assert!(err.contains("IfBegin blocks nested deeper than the limit of 50"), "{err}");
}

#[test]
fn unbalanced_blocks_are_errors() {
    assert!(load_err("WorldBegin\nIfEnd\nWorldEnd\n").contains("test.rib:2:1: error: IfEnd without IfBegin"));
    assert!(load_err("WorldBegin\nElse\nWorldEnd\n").contains("Else without IfBegin"));
    assert!(
        load_err("WorldBegin\nIfBegin \"true\"\nElse\nElse\nIfEnd\nWorldEnd\n").contains("Else after Else")
    );
    assert!(load_err("WorldBegin\nIfBegin \"true\"\nWorldEnd\n").contains("IfBegin is never closed"));
}

#[test]
fn resources_save_and_restore_attributes_and_transforms() {
    let rib = r#"
WorldBegin
Color [1 0 0]
Translate 1 0 0
Resource "red" "attributes" "string operation" ["save"]
Color [0 1 0]
Translate 0 5 0
Sphere 1 -1 1 360
Resource "red" "attributes" "string operation" ["restore"]
Sphere 2 -2 2 360
Color [0 0 1]
Resource "red" "attributes" "string operation" ["restore"] "string subset" ["transform"]
Sphere 3 -3 3 360
ResourceBegin
  Resource "inner" "attributes" "string operation" ["save"]
ResourceEnd
WorldEnd
"#;
    let loaded = load(rib);
    let s = &loaded.scene;
    let color = |i: usize| s.attributes_of(s.shapes[i].attributes).color;
    let offset = |i: usize| s.shapes[i].world_from_object.w_axis.truncate();
    assert_eq!(color(0), glam::Vec3::new(0.0, 1.0, 0.0));
    assert_eq!(offset(0), glam::DVec3::new(1.0, 5.0, 0.0));
    assert_eq!(color(1), glam::Vec3::new(1.0, 0.0, 0.0));
    assert_eq!(offset(1), glam::DVec3::new(1.0, 0.0, 0.0));
    // The transform subset leaves the colour alone.
    assert_eq!(color(2), glam::Vec3::new(0.0, 0.0, 1.0));
    assert_eq!(offset(2), glam::DVec3::new(1.0, 0.0, 0.0));

    let err = load_err(
        "WorldBegin\nResourceBegin\nResource \"x\" \"attributes\" \"string operation\" [\"save\"]\nResourceEnd\nResource \"x\" \"attributes\" \"string operation\" [\"restore\"]\nWorldEnd\n",
    );
    assert!(err.contains("no resource of that name"), "{err}");
    assert!(load_err("WorldBegin\nResourceEnd\nWorldEnd\n").contains("ResourceEnd without ResourceBegin"));
    let odd = load("WorldBegin\nResource \"x\" \"attributes\" \"string operation\" [\"concat\"]\nWorldEnd\n");
    assert!(
        odd.diagnostics.render(&odd.sources).contains(
            "test.rib:2:1: warning: Resource \"x\" \"attributes\": \"operation\" must be \"save\", \"restore\" or \"load\", got \"concat\"; ignored"
        ),
        "{}",
        odd.render_warnings()
    );
}

#[path = "support/corpus_fs.rs"]
mod corpus_fs;

fn load_corpus(repo: &str, file: &str) -> rib_parser::Loaded {
    let options = LoadOptions {
        read: rib_parser::ReadOptions {
            file_system: std::sync::Arc::new(corpus_fs::CorpusFs::new()),
            ..Default::default()
        },
        frame: None,
    };
    rib_parser::load_scene(&corpus_fs::CorpusFs::virtual_path(repo, file), &options)
        .unwrap_or_else(|e| panic!("{}", e.render()))
}

#[test]
fn corpus_files_with_conditionals() {
    // RiCPP's request test: the IfBegin branch is false (`... && false`), the ElseIf branch
    // true by its regular expression, so only the full sphere of radius 1 is built there.
    for file in ["ricpp2__RibSamples__testcommands.rib", "ricpp2__RibSamples__Archive.rib"] {
        let loaded = load_corpus("s-cherepanov__ricpp", file);
        let spheres: Vec<(f32, f32)> = loaded
            .scene
            .shapes
            .iter()
            .filter_map(|s| match *s.shape {
                Shape::Sphere { radius, theta_max_degrees, .. } => Some((radius, theta_max_degrees)),
                _ => None,
            })
            .collect();
        assert!(spheres.contains(&(1.0, 360.0)), "{spheres:?}");
        assert!(!spheres.contains(&(0.75, 360.0)) && !spheres.contains(&(1.0, 180.0)), "{spheres:?}");
        let warnings = loaded.diagnostics.render(&loaded.sources);
        assert!(!warnings.contains("IfBegin") && !warnings.contains("'Resource"), "{warnings}");
    }
}
