//! RenderMan's conditional expressions (`IfBegin`/`ElseIf`, PRMan's "conditional RIB").
//!
//! # Grammar
//! ```text
//! expr     := and ("||" and)*
//! and      := compare ("&&" compare)*
//! compare  := sum (("==" | "!=" | "<" | "<=" | ">" | ">=" | "=~") sum)?
//! sum      := product (("+" | "-") product)*
//! product  := unary (("*" | "/") unary)*
//! unary    := ("!" | "-") unary | primary
//! primary  := number | 'string' | "string" | true | false | variable
//!           | concat(expr, ...) | defined(name) | "(" expr ")"
//! variable := $name | ${name} | $(name)      name: letters, digits, '_' and ':'
//! ```
//! Variables name options and attributes as PRMan does: `$Frame` (the `FrameBegin` number),
//! `$Option:user:pass` and `$Attribute:user:pass` (one class), `$user:pass` (attributes first,
//! then options), and a bare `$pass` (any namespace's parameter of that name, attributes first).
//! Inside `${...}` and quoted strings, references are expanded first, so
//! `'${Option:${table}:$name}'` works. A string escapes its quote and `$` with a backslash;
//! other backslashes stay (they belong to the regular expression of `=~`).
//!
//! # Semantics
//! `&&` and `||` short-circuit. `==`, `!=` and the orderings compare numerically when one side
//! is a number and the other reads as one (`29 == '29'`), otherwise as strings. `=~` matches
//! the left side against the right side as a regular expression (found anywhere, as Perl's
//! `=~`). Arithmetic needs numbers. An expression is true when its value is `true`, a non-zero
//! number, or a non-empty string. A reference to an undefined variable is an error; test with
//! `defined(name)` first.

use regex::RegexBuilder;

/// The value of an expression or a variable.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Number(f64),
    Str(String),
    Bool(bool),
}

impl Value {
    fn truthy(&self) -> bool {
        match self {
            Value::Number(n) => *n != 0.0,
            Value::Str(s) => !s.is_empty(),
            Value::Bool(b) => *b,
        }
    }

    fn as_number(&self) -> Option<f64> {
        match self {
            Value::Number(n) => Some(*n),
            Value::Str(s) => s.trim().parse::<f64>().ok().filter(|n| n.is_finite()),
            Value::Bool(b) => Some(if *b { 1.0 } else { 0.0 }),
        }
    }

    fn text(&self) -> String {
        match self {
            Value::Number(n) if n.fract() == 0.0 && n.abs() < 1e15 => format!("{}", *n as i64),
            Value::Number(n) => format!("{n}"),
            Value::Str(s) => s.clone(),
            Value::Bool(b) => b.to_string(),
        }
    }
}

/// Where an expression's variables come from.
pub trait Variables {
    /// The value of the variable `name` (`Frame`, `Option:user:pass`, `user:pass`, ...), or
    /// `None` when it is not defined.
    fn lookup(&self, name: &str) -> Option<Value>;
}

/// What is wrong with an expression, and where: a byte offset into the expression text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExprError {
    pub offset: usize,
    pub message: String,
}

/// The most deeply nested parentheses, operators and references an expression may have, so a
/// hostile expression cannot exhaust the stack.
const MAX_DEPTH: usize = 64;
/// The compiled size limit of a `=~` regular expression (bytes).
const REGEX_SIZE_LIMIT: usize = 1 << 20;

/// Evaluates `expr` to true or false.
pub fn evaluate(expr: &str, vars: &dyn Variables) -> Result<bool, ExprError> {
    let tokens = lex(expr)?;
    let mut parser = Parser { tokens: &tokens, pos: 0, depth: 0, len: expr.len() };
    let node = parser.or()?;
    if let Some(tok) = parser.tokens.get(parser.pos) {
        return Err(ExprError { offset: tok.offset, message: format!("unexpected {}", tok.kind.describe()) });
    }
    Ok(eval(&node, vars, 0)?.truthy())
}

#[derive(Clone, Debug, PartialEq)]
enum Kind {
    Number(f64),
    /// A quoted string, still to expand (`$` references).
    Str(String),
    /// A `$` reference: the name, still to expand when it came in braces.
    Var(String),
    Name(String),
    Op(&'static str),
    Open,
    Close,
    Comma,
}

impl Kind {
    fn describe(&self) -> String {
        match self {
            Kind::Number(n) => format!("number {n}"),
            Kind::Str(s) => format!("string '{s}'"),
            Kind::Var(v) => format!("variable ${v}"),
            Kind::Name(n) => format!("name '{n}'"),
            Kind::Op(op) => format!("'{op}'"),
            Kind::Open => "'('".into(),
            Kind::Close => "')'".into(),
            Kind::Comma => "','".into(),
        }
    }
}

#[derive(Clone, Debug)]
struct Token {
    kind: Kind,
    offset: usize,
}

const OPERATORS: &[&str] = &["==", "!=", "<=", ">=", "=~", "&&", "||", "<", ">", "!", "+", "-", "*", "/"];

fn is_name_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_' || c == ':'
}

fn lex(expr: &str) -> Result<Vec<Token>, ExprError> {
    let mut tokens = Vec::new();
    let chars: Vec<(usize, char)> = expr.char_indices().collect();
    let mut i = 0;
    while i < chars.len() {
        let (offset, c) = chars[i];
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        let kind = match c {
            '(' => {
                i += 1;
                Kind::Open
            }
            ')' => {
                i += 1;
                Kind::Close
            }
            ',' => {
                i += 1;
                Kind::Comma
            }
            '\'' | '"' => {
                let (text, next) = quoted(&chars, i)?;
                i = next;
                Kind::Str(text)
            }
            '$' => {
                let (name, next) = reference(&chars, i, expr)?;
                i = next;
                Kind::Var(name)
            }
            c if c.is_ascii_digit()
                || (c == '.' && chars.get(i + 1).is_some_and(|(_, d)| d.is_ascii_digit())) =>
            {
                let start = i;
                while i < chars.len()
                    && (chars[i].1.is_ascii_alphanumeric()
                        || chars[i].1 == '.'
                        || ((chars[i].1 == '+' || chars[i].1 == '-') && matches!(chars[i - 1].1, 'e' | 'E')))
                {
                    i += 1;
                }
                let end = chars.get(i).map_or(expr.len(), |(o, _)| *o);
                let text = &expr[offset..end];
                match text.parse::<f64>() {
                    Ok(n) if n.is_finite() => Kind::Number(n),
                    _ => {
                        return Err(ExprError {
                            offset: chars[start].0,
                            message: format!("'{text}' is not a number"),
                        });
                    }
                }
            }
            c if c.is_ascii_alphabetic() || c == '_' => {
                let start = offset;
                while i < chars.len() && is_name_char(chars[i].1) {
                    i += 1;
                }
                let end = chars.get(i).map_or(expr.len(), |(o, _)| *o);
                Kind::Name(expr[start..end].to_string())
            }
            _ => {
                let rest = &expr[offset..];
                let Some(op) = OPERATORS.iter().find(|op| rest.starts_with(**op)) else {
                    let message = match c {
                        '=' => "'=' is not an operator: compare with '=='".to_string(),
                        '&' | '|' => format!("'{c}' alone is not an operator: use '{c}{c}'"),
                        _ => format!("unexpected character '{c}'"),
                    };
                    return Err(ExprError { offset, message });
                };
                i += op.chars().count();
                Kind::Op(op)
            }
        };
        tokens.push(Token { kind, offset });
    }
    Ok(tokens)
}

/// A quoted string starting at `chars[i]`: its text (escapes of the quote, `\` and `$` that
/// precede them resolved later) and the index after the closing quote.
fn quoted(chars: &[(usize, char)], i: usize) -> Result<(String, usize), ExprError> {
    let (offset, quote) = chars[i];
    let mut j = i + 1;
    let mut text = String::new();
    while j < chars.len() {
        let c = chars[j].1;
        if c == '\\' && j + 1 < chars.len() {
            // Keep the backslash: `expand` resolves `\'`, `\"` and `\$`, and leaves the others
            // to the regular expression.
            text.push(c);
            text.push(chars[j + 1].1);
            j += 2;
            continue;
        }
        if c == quote {
            return Ok((text, j + 1));
        }
        text.push(c);
        j += 1;
    }
    Err(ExprError { offset, message: format!("the string starting here has no closing {quote}") })
}

/// A `$` reference starting at `chars[i]`: the name (braced names kept raw, to be expanded)
/// and the index after it.
fn reference(chars: &[(usize, char)], i: usize, expr: &str) -> Result<(String, usize), ExprError> {
    let offset = chars[i].0;
    let Some(&(_, next)) = chars.get(i + 1) else {
        return Err(ExprError { offset, message: "'$' must be followed by a variable name".into() });
    };
    if next == '{' || next == '(' {
        let close = if next == '{' { '}' } else { ')' };
        let mut depth = 0usize;
        let mut j = i + 1;
        while j < chars.len() {
            let c = chars[j].1;
            if c == next {
                depth += 1;
            } else if c == close {
                depth -= 1;
                if depth == 0 {
                    let inner = &expr[chars[i + 2].0.min(chars[j].0)..chars[j].0];
                    if inner.trim().is_empty() {
                        return Err(ExprError { offset, message: "empty variable reference".into() });
                    }
                    return Ok((inner.to_string(), j + 1));
                }
            }
            j += 1;
        }
        return Err(ExprError {
            offset,
            message: format!("the variable reference has no closing '{close}'"),
        });
    }
    let mut j = i + 1;
    while j < chars.len() && is_name_char(chars[j].1) {
        j += 1;
    }
    // A trailing ':' separates the name from what follows (`${Option:$table:$name}`).
    while j > i + 1 && chars[j - 1].1 == ':' {
        j -= 1;
    }
    if j == i + 1 {
        return Err(ExprError { offset, message: "'$' must be followed by a variable name".into() });
    }
    let end = chars.get(j).map_or(expr.len(), |(o, _)| *o);
    Ok((expr[chars[i + 1].0..end].to_string(), j))
}

#[derive(Debug)]
enum Node {
    Literal(Value),
    Str(String, usize),
    Var(String, usize),
    Not(Box<Node>),
    Neg(Box<Node>, usize),
    Binary(&'static str, Box<Node>, Box<Node>, usize),
    Concat(Vec<Node>),
    Defined(String, usize),
}

struct Parser<'a> {
    tokens: &'a [Token],
    pos: usize,
    depth: usize,
    /// The expression's length: where "at the end" errors point.
    len: usize,
}

impl Parser<'_> {
    fn peek_op(&self) -> Option<&'static str> {
        match self.tokens.get(self.pos) {
            Some(Token { kind: Kind::Op(op), .. }) => Some(op),
            _ => None,
        }
    }

    fn end_offset(&self) -> usize {
        self.len
    }

    fn deeper(&mut self) -> Result<(), ExprError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            let offset = self.tokens.get(self.pos).map_or(self.end_offset(), |t| t.offset);
            return Err(ExprError { offset, message: format!("nested more than {MAX_DEPTH} deep") });
        }
        Ok(())
    }

    fn binary_level(
        &mut self,
        ops: &[&'static str],
        next: fn(&mut Self) -> Result<Node, ExprError>,
        once: bool,
    ) -> Result<Node, ExprError> {
        self.deeper()?;
        let mut left = next(self)?;
        while let Some(op) = self.peek_op().filter(|op| ops.contains(op)) {
            let offset = self.tokens[self.pos].offset;
            self.pos += 1;
            let right = next(self)?;
            left = Node::Binary(op, Box::new(left), Box::new(right), offset);
            if once {
                break;
            }
        }
        self.depth -= 1;
        Ok(left)
    }

    fn or(&mut self) -> Result<Node, ExprError> {
        self.binary_level(&["||"], Self::and, false)
    }

    fn and(&mut self) -> Result<Node, ExprError> {
        self.binary_level(&["&&"], Self::compare, false)
    }

    fn compare(&mut self) -> Result<Node, ExprError> {
        self.binary_level(&["==", "!=", "<", "<=", ">", ">=", "=~"], Self::sum, true)
    }

    fn sum(&mut self) -> Result<Node, ExprError> {
        self.binary_level(&["+", "-"], Self::product, false)
    }

    fn product(&mut self) -> Result<Node, ExprError> {
        self.binary_level(&["*", "/"], Self::unary, false)
    }

    fn unary(&mut self) -> Result<Node, ExprError> {
        self.deeper()?;
        let node = match self.peek_op() {
            Some("!") => {
                self.pos += 1;
                Node::Not(Box::new(self.unary()?))
            }
            Some("-") => {
                let offset = self.tokens[self.pos].offset;
                self.pos += 1;
                Node::Neg(Box::new(self.unary()?), offset)
            }
            _ => self.primary()?,
        };
        self.depth -= 1;
        Ok(node)
    }

    fn expect(&mut self, kind: &Kind, what: &str) -> Result<(), ExprError> {
        match self.tokens.get(self.pos) {
            Some(t) if &t.kind == kind => {
                self.pos += 1;
                Ok(())
            }
            Some(t) => Err(ExprError {
                offset: t.offset,
                message: format!("expected {what}, found {}", t.kind.describe()),
            }),
            None => {
                Err(ExprError { offset: self.end_offset(), message: format!("expected {what} at the end") })
            }
        }
    }

    fn primary(&mut self) -> Result<Node, ExprError> {
        let Some(tok) = self.tokens.get(self.pos).cloned() else {
            return Err(ExprError {
                offset: self.end_offset(),
                message: "the expression ends where a value was expected".into(),
            });
        };
        self.pos += 1;
        Ok(match tok.kind {
            Kind::Number(n) => Node::Literal(Value::Number(n)),
            Kind::Str(s) => Node::Str(s, tok.offset),
            Kind::Var(v) => Node::Var(v, tok.offset),
            Kind::Open => {
                let inner = self.or()?;
                self.expect(&Kind::Close, "')'")?;
                inner
            }
            Kind::Name(name) => match name.as_str() {
                "true" => Node::Literal(Value::Bool(true)),
                "false" => Node::Literal(Value::Bool(false)),
                "concat" => {
                    self.expect(&Kind::Open, "'(' after concat")?;
                    let mut args = Vec::new();
                    if self.tokens.get(self.pos).map(|t| &t.kind) != Some(&Kind::Close) {
                        loop {
                            args.push(self.or()?);
                            if self.tokens.get(self.pos).map(|t| &t.kind) == Some(&Kind::Comma) {
                                self.pos += 1;
                            } else {
                                break;
                            }
                        }
                    }
                    self.expect(&Kind::Close, "')' to close concat")?;
                    Node::Concat(args)
                }
                "defined" => {
                    self.expect(&Kind::Open, "'(' after defined")?;
                    let arg = self.tokens.get(self.pos).cloned();
                    let name = match arg.as_ref().map(|t| &t.kind) {
                        Some(Kind::Name(n) | Kind::Var(n) | Kind::Str(n)) => n.clone(),
                        _ => {
                            let offset = arg.map_or(self.end_offset(), |t| t.offset);
                            return Err(ExprError {
                                offset,
                                message: "defined() takes a variable name".into(),
                            });
                        }
                    };
                    self.pos += 1;
                    self.expect(&Kind::Close, "')' to close defined")?;
                    Node::Defined(name, tok.offset)
                }
                other => {
                    return Err(ExprError {
                        offset: tok.offset,
                        message: format!(
                            "unknown name '{other}' (strings are quoted, variables start with '$', functions are concat and defined)"
                        ),
                    });
                }
            },
            other => {
                return Err(ExprError {
                    offset: tok.offset,
                    message: format!("expected a value, found {}", other.describe()),
                });
            }
        })
    }
}

/// Expands `$` references and escapes in `text` (a string literal or a braced name) that
/// starts at byte `offset` of the expression.
fn expand(text: &str, offset: usize, vars: &dyn Variables, depth: usize) -> Result<String, ExprError> {
    if depth > MAX_DEPTH {
        return Err(ExprError {
            offset,
            message: format!("variable references nested more than {MAX_DEPTH} deep"),
        });
    }
    let chars: Vec<(usize, char)> = text.char_indices().collect();
    let mut out = String::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i].1;
        if c == '\\' && i + 1 < chars.len() && matches!(chars[i + 1].1, '\'' | '"' | '$') {
            out.push(chars[i + 1].1);
            i += 2;
            continue;
        }
        if c == '$'
            && i + 1 < chars.len()
            && (is_name_char(chars[i + 1].1) || matches!(chars[i + 1].1, '{' | '('))
        {
            let (name, next) =
                reference(&chars, i, text).map_err(|e| ExprError { offset: offset + e.offset, ..e })?;
            out.push_str(&resolve(&name, offset + chars[i].0, vars, depth + 1)?.text());
            i = next;
            continue;
        }
        out.push(c);
        i += 1;
    }
    Ok(out)
}

/// The value of the reference `$name` (its name expanded first).
fn resolve(name: &str, offset: usize, vars: &dyn Variables, depth: usize) -> Result<Value, ExprError> {
    let name = expand(name, offset, vars, depth)?;
    vars.lookup(name.trim()).ok_or_else(|| ExprError {
        offset,
        message: format!(
            "${name} is not defined (no such option, attribute or frame number; test with defined({name}))"
        ),
    })
}

fn eval(node: &Node, vars: &dyn Variables, depth: usize) -> Result<Value, ExprError> {
    Ok(match node {
        Node::Literal(v) => v.clone(),
        Node::Str(s, offset) => Value::Str(expand(s, offset + 1, vars, depth)?),
        Node::Var(name, offset) => resolve(name, *offset, vars, depth)?,
        Node::Not(inner) => Value::Bool(!eval(inner, vars, depth)?.truthy()),
        Node::Neg(inner, offset) => {
            let v = eval(inner, vars, depth)?;
            let n = v.as_number().ok_or_else(|| ExprError {
                offset: *offset,
                message: format!("'-' needs a number, got '{}'", v.text()),
            })?;
            Value::Number(-n)
        }
        Node::Concat(args) => {
            let mut out = String::new();
            for a in args {
                out.push_str(&eval(a, vars, depth)?.text());
            }
            Value::Str(out)
        }
        Node::Defined(name, offset) => {
            let name = expand(name, *offset, vars, depth)?;
            Value::Bool(vars.lookup(name.trim()).is_some())
        }
        Node::Binary(op, l, r, offset) => {
            let left = eval(l, vars, depth)?;
            match *op {
                "&&" => return Ok(Value::Bool(left.truthy() && eval(r, vars, depth)?.truthy())),
                "||" => return Ok(Value::Bool(left.truthy() || eval(r, vars, depth)?.truthy())),
                _ => {}
            }
            let right = eval(r, vars, depth)?;
            binary(op, &left, &right, *offset)?
        }
    })
}

fn binary(op: &str, left: &Value, right: &Value, offset: usize) -> Result<Value, ExprError> {
    if op == "=~" {
        let pattern = right.text();
        let re = RegexBuilder::new(&pattern).size_limit(REGEX_SIZE_LIMIT).build().map_err(|e| ExprError {
            offset,
            message: format!("'{pattern}' is not a regular expression: {}", first_line(&e.to_string())),
        })?;
        return Ok(Value::Bool(re.is_match(&left.text())));
    }
    if matches!(op, "+" | "-" | "*" | "/") {
        let number = |v: &Value| {
            v.as_number().ok_or_else(|| ExprError {
                offset,
                message: format!("'{op}' needs numbers, got '{}'", v.text()),
            })
        };
        let (a, b) = (number(left)?, number(right)?);
        if op == "/" && b == 0.0 {
            return Err(ExprError { offset, message: "division by zero".into() });
        }
        return Ok(Value::Number(match op {
            "+" => a + b,
            "-" => a - b,
            "*" => a * b,
            _ => a / b,
        }));
    }
    let numeric = matches!(left, Value::Number(_) | Value::Bool(_))
        || matches!(right, Value::Number(_) | Value::Bool(_));
    let ordering = match (numeric, left.as_number(), right.as_number()) {
        (true, Some(a), Some(b)) => a.partial_cmp(&b),
        _ => Some(left.text().cmp(&right.text())),
    };
    use std::cmp::Ordering::*;
    Ok(Value::Bool(match (op, ordering) {
        ("==", o) => o == Some(Equal),
        ("!=", o) => o != Some(Equal),
        ("<", o) => o == Some(Less),
        ("<=", o) => matches!(o, Some(Less | Equal)),
        (">", o) => o == Some(Greater),
        (">=", o) => matches!(o, Some(Greater | Equal)),
        _ => return Err(ExprError { offset, message: format!("unknown operator '{op}'") }),
    }))
}

fn first_line(s: &str) -> String {
    s.lines().rfind(|l| !l.trim().is_empty()).unwrap_or(s).trim().to_string()
}
