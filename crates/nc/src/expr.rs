//! Parameters (`#1`, `#<name>`) and expressions (`[#1 * 2]`, `SIN[30]`):
//! the syntax tree, its parser over a normalised line, and its evaluation.
//!
//! Semantics follow LinuxCNC: angles in degrees, `EQ`/`NE` compare within
//! 1e-4 (program units), `MOD` gives a result with the sign of the divisor's
//! magnitude, operators of equal precedence associate to the left.

use std::collections::HashMap;

use crate::cursor::{Cursor, SyntaxError};

/// Deepest nesting of brackets/functions/parameter indirection accepted.
const MAX_DEPTH: u32 = 64;
/// Highest numbered parameter (LinuxCNC's RS274NGC_MAX_PARAMETERS − 1).
pub const MAX_NUMBERED: usize = 5601;
/// Tolerance of `EQ`/`NE` and friends (LinuxCNC's TOLERANCE_EQUAL).
const TOLERANCE_EQUAL: f64 = 1e-4;

/// An unevaluated expression: 16 bytes, a number inline, everything else
/// behind one box (a parsed program keeps one per word of every line).
#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    Num(f64),
    Param(Box<ParamRef>),
    Neg(Box<Expr>),
    Func(Func, Box<Expr>),
    /// `ATAN[y]/[x]`, degrees.
    Atan(Box<[Expr; 2]>),
    /// Operator, left and right operand.
    Bin(BinOp, Box<[Expr; 2]>),
    /// `EXISTS[#<name>]` (a thin box: `Box<str>` would make every
    /// expression 24 bytes).
    #[allow(clippy::box_collection)]
    Exists(Box<String>),
}

/// A parameter reference: `#5`, `#[expr]`, `##1` or `#<name>`.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamRef {
    Numbered(Expr),
    /// Lower-case name without the angle brackets.
    Named(String),
}

/// Unary functions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Func {
    Abs,
    Acos,
    Asin,
    Cos,
    Exp,
    Fix,
    Fup,
    Ln,
    Round,
    Sin,
    Sqrt,
    Tan,
}

/// Binary operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinOp {
    Pow,
    Mul,
    Div,
    Mod,
    Add,
    Sub,
    Eq,
    Ne,
    Gt,
    Ge,
    Lt,
    Le,
    And,
    Or,
    Xor,
}

impl BinOp {
    fn precedence(self) -> u8 {
        match self {
            BinOp::Pow => 6,
            BinOp::Mul | BinOp::Div | BinOp::Mod => 5,
            BinOp::Add | BinOp::Sub => 4,
            BinOp::Eq | BinOp::Ne | BinOp::Gt | BinOp::Ge | BinOp::Lt | BinOp::Le => 3,
            BinOp::And | BinOp::Or | BinOp::Xor => 2,
        }
    }
}

const FUNCS: [(&str, Func); 12] = [
    ("abs", Func::Abs),
    ("acos", Func::Acos),
    ("asin", Func::Asin),
    ("cos", Func::Cos),
    ("exp", Func::Exp),
    ("fix", Func::Fix),
    ("fup", Func::Fup),
    ("ln", Func::Ln),
    ("round", Func::Round),
    ("sin", Func::Sin),
    ("sqrt", Func::Sqrt),
    ("tan", Func::Tan),
];

const OPS: [(&str, BinOp); 15] = [
    ("**", BinOp::Pow),
    ("*", BinOp::Mul),
    ("/", BinOp::Div),
    ("mod", BinOp::Mod),
    ("+", BinOp::Add),
    ("-", BinOp::Sub),
    ("eq", BinOp::Eq),
    ("ne", BinOp::Ne),
    ("gt", BinOp::Gt),
    ("ge", BinOp::Ge),
    ("lt", BinOp::Lt),
    ("le", BinOp::Le),
    ("and", BinOp::And),
    ("or", BinOp::Or),
    ("xor", BinOp::Xor),
];

/// Reads a real value: a number, `[expr]`, a parameter, a function call,
/// optionally preceded by unary `+`/`-`.
pub fn parse_value(cur: &mut Cursor, depth: u32) -> Result<Expr, SyntaxError> {
    if depth > MAX_DEPTH {
        return Err(cur.error("expression nested too deeply"));
    }
    match cur.peek() {
        Some('-') => {
            cur.bump();
            Ok(Expr::Neg(Box::new(parse_value(cur, depth + 1)?)))
        }
        Some('+') => {
            cur.bump();
            parse_value(cur, depth + 1)
        }
        Some('[') => parse_bracketed(cur, depth + 1),
        Some('#') => Ok(Expr::Param(Box::new(parse_param(cur, depth + 1)?))),
        Some(c) if c.is_ascii_digit() || c == '.' => Ok(Expr::Num(cur.number()?)),
        Some(c) if c.is_ascii_alphabetic() => parse_function(cur, depth + 1),
        Some(c) => Err(cur.error(&format!("expected a number, found '{c}'"))),
        None => Err(cur.error("expected a number at end of line")),
    }
}

/// Reads `#…` (the cursor is on `#`).
pub fn parse_param(cur: &mut Cursor, depth: u32) -> Result<ParamRef, SyntaxError> {
    if depth > MAX_DEPTH {
        return Err(cur.error("expression nested too deeply"));
    }
    cur.bump(); // '#'
    if cur.peek() == Some('<') {
        let name = cur.angle_name("named parameter not closed with '>'")?;
        if name.is_empty() {
            return Err(cur.error("empty parameter name"));
        }
        return Ok(ParamRef::Named(name));
    }
    let index = match cur.peek() {
        Some('[') => parse_bracketed(cur, depth + 1)?,
        Some('#') => Expr::Param(Box::new(parse_param(cur, depth + 1)?)),
        Some(c) if c.is_ascii_digit() || c == '.' => Expr::Num(cur.number()?),
        _ => return Err(cur.error("expected a parameter number or <name> after '#'")),
    };
    Ok(ParamRef::Numbered(index))
}

fn parse_bracketed(cur: &mut Cursor, depth: u32) -> Result<Expr, SyntaxError> {
    if depth > MAX_DEPTH {
        return Err(cur.error("expression nested too deeply"));
    }
    cur.bump(); // '['
    let mut operands = vec![parse_value(cur, depth + 1)?];
    let mut operators: Vec<BinOp> = Vec::new();
    loop {
        if cur.peek() == Some(']') {
            cur.bump();
            break;
        }
        let op = read_operator(cur)?;
        while let Some(&top) = operators.last() {
            if top.precedence() >= op.precedence() {
                reduce(&mut operands, &mut operators);
            } else {
                break;
            }
        }
        operators.push(op);
        operands.push(parse_value(cur, depth + 1)?);
    }
    while !operators.is_empty() {
        reduce(&mut operands, &mut operators);
    }
    Ok(operands.pop().unwrap_or(Expr::Num(0.0)))
}

fn reduce(operands: &mut Vec<Expr>, operators: &mut Vec<BinOp>) {
    if let (Some(op), Some(rhs), Some(lhs)) = (operators.pop(), operands.pop(), operands.pop()) {
        operands.push(Expr::Bin(op, Box::new([lhs, rhs])));
    }
}

fn read_operator(cur: &mut Cursor) -> Result<BinOp, SyntaxError> {
    if let Some(op) = cur.eat_any(&OPS) {
        return Ok(op);
    }
    match cur.peek() {
        None => Err(cur.error("expression not closed with ']'")),
        Some(c) => Err(cur.error(&format!("expected an operator or ']', found '{c}'"))),
    }
}

fn parse_function(cur: &mut Cursor, depth: u32) -> Result<Expr, SyntaxError> {
    if cur.eat_str("atan") {
        expect_bracket(cur)?;
        let y = parse_bracketed(cur, depth + 1)?;
        if !cur.eat_str("/") || cur.peek() != Some('[') {
            return Err(cur.error("ATAN needs the form ATAN[y]/[x]"));
        }
        let x = parse_bracketed(cur, depth + 1)?;
        return Ok(Expr::Atan(Box::new([y, x])));
    }
    if cur.eat_str("exists") {
        expect_bracket(cur)?;
        cur.bump();
        if cur.peek() != Some('#') {
            return Err(cur.error("EXISTS needs a named parameter: EXISTS[#<name>]"));
        }
        let ParamRef::Named(name) = parse_param(cur, depth + 1)? else {
            return Err(cur.error("EXISTS needs a named parameter: EXISTS[#<name>]"));
        };
        if !cur.eat_str("]") {
            return Err(cur.error("expected ']'"));
        }
        return Ok(Expr::Exists(Box::new(name)));
    }
    if let Some(f) = cur.eat_any(&FUNCS) {
        expect_bracket(cur)?;
        return Ok(Expr::Func(f, Box::new(parse_bracketed(cur, depth + 1)?)));
    }
    let word: String = cur
        .rest()
        .chars()
        .take_while(|c| c.is_ascii_alphabetic())
        .collect();
    Err(cur.error(&format!("expected a number, found '{word}'")))
}

fn expect_bracket(cur: &Cursor) -> Result<(), SyntaxError> {
    if cur.peek() == Some('[') {
        Ok(())
    } else {
        Err(cur.error("expected '[' after function name"))
    }
}

/// Parameter store: numbered parameters, global named parameters (`#<_x>`)
/// and one scope of local named parameters per active `o… call`.
#[derive(Clone, Debug)]
pub struct Params {
    numbered: Vec<f64>,
    globals: HashMap<String, f64>,
    locals: Vec<HashMap<String, f64>>,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            numbered: vec![0.0; MAX_NUMBERED + 1],
            globals: HashMap::new(),
            locals: Vec::new(),
        }
    }
}

impl Params {
    /// Value of numbered parameter `n` (1 ≤ n ≤ 5601).
    pub fn numbered(&self, n: usize) -> f64 {
        self.numbered.get(n).copied().unwrap_or(0.0)
    }

    /// Sets numbered parameter `n`; `n` must have been checked with [`Params::index`].
    pub fn set_numbered(&mut self, n: usize, value: f64) {
        if let Some(slot) = self.numbered.get_mut(n) {
            *slot = value;
        }
    }

    /// Checks a numbered-parameter index given as a real number, read as
    /// LinuxCNC reads it ([`crate::gcode::integer_value`]: #0.99995 is #1).
    pub fn index(value: f64) -> Result<usize, String> {
        match crate::gcode::integer_value(value) {
            Some(n) if (1..=MAX_NUMBERED as i64).contains(&n) => Ok(n as usize),
            _ => Err(format!(
                "parameter number {value} out of range 1..{MAX_NUMBERED}"
            )),
        }
    }

    fn named(&self, name: &str) -> Option<f64> {
        if name.starts_with('_') {
            return self.globals.get(name).copied();
        }
        match self.locals.last() {
            Some(scope) => scope.get(name).copied(),
            None => self.globals.get(name).copied(),
        }
    }

    /// Sets a named parameter in the scope its name selects.
    pub fn set_named(&mut self, name: &str, value: f64) {
        let scope = match self.locals.last_mut() {
            Some(scope) if !name.starts_with('_') => scope,
            _ => &mut self.globals,
        };
        scope.insert(name.to_owned(), value);
    }

    /// Opens a subroutine scope; returns the saved `#1..#30`.
    pub fn push_scope(&mut self, args: &[f64]) -> [f64; 30] {
        let mut saved = [0.0; 30];
        saved.copy_from_slice(&self.numbered[1..=30]);
        for (i, slot) in self.numbered[1..=30].iter_mut().enumerate() {
            *slot = args.get(i).copied().unwrap_or(0.0);
        }
        self.locals.push(HashMap::new());
        saved
    }

    /// Closes a subroutine scope, restoring `#1..#30`.
    pub fn pop_scope(&mut self, saved: &[f64; 30]) {
        self.numbered[1..=30].copy_from_slice(saved);
        self.locals.pop();
    }

    /// Evaluates a parameter reference to its index or name, for assignment.
    pub fn resolve(&self, target: &ParamRef) -> Result<Target, String> {
        match target {
            ParamRef::Named(name) => Ok(Target::Named(name.clone())),
            ParamRef::Numbered(index) => Ok(Target::Numbered(Params::index(self.eval(index)?)?)),
        }
    }

    /// Assigns a resolved target.
    pub fn assign(&mut self, target: &Target, value: f64) {
        match target {
            Target::Named(name) => self.set_named(name, value),
            Target::Numbered(n) => self.set_numbered(*n, value),
        }
    }

    /// Evaluates an expression.
    pub fn eval(&self, e: &Expr) -> Result<f64, String> {
        let v = match e {
            Expr::Num(v) => *v,
            Expr::Param(p) => match p.as_ref() {
                ParamRef::Named(name) => self
                    .named(name)
                    .ok_or_else(|| format!("named parameter #<{name}> is not defined"))?,
                ParamRef::Numbered(index) => self.numbered(Params::index(self.eval(index)?)?),
            },
            Expr::Neg(inner) => -self.eval(inner)?,
            Expr::Exists(name) => f64::from(u8::from(self.named(name).is_some())),
            Expr::Atan(yx) => self.eval(&yx[0])?.atan2(self.eval(&yx[1])?).to_degrees(),
            Expr::Func(f, arg) => apply_func(*f, self.eval(arg)?)?,
            Expr::Bin(op, operands) => {
                apply_op(*op, self.eval(&operands[0])?, self.eval(&operands[1])?)?
            }
        };
        if v.is_finite() {
            Ok(v)
        } else {
            Err("expression result is not a finite number".into())
        }
    }
}

/// An assignment target after evaluation of its index.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    Numbered(usize),
    Named(String),
}

fn apply_func(f: Func, x: f64) -> Result<f64, String> {
    Ok(match f {
        Func::Abs => x.abs(),
        Func::Acos | Func::Asin if !(-1.0..=1.0).contains(&x) => {
            return Err(format!("argument {x} of ACOS/ASIN outside [-1, 1]"));
        }
        Func::Acos => x.acos().to_degrees(),
        Func::Asin => x.asin().to_degrees(),
        Func::Cos => x.to_radians().cos(),
        Func::Exp => x.exp(),
        Func::Fix => x.floor(),
        Func::Fup => x.ceil(),
        Func::Ln if x <= 0.0 => return Err(format!("LN of non-positive number {x}")),
        Func::Ln => x.ln(),
        Func::Round => x.round(),
        Func::Sin => x.to_radians().sin(),
        Func::Sqrt if x < 0.0 => return Err(format!("SQRT of negative number {x}")),
        Func::Sqrt => x.sqrt(),
        Func::Tan => x.to_radians().tan(),
    })
}

fn apply_op(op: BinOp, a: f64, b: f64) -> Result<f64, String> {
    let truth = |t: bool| f64::from(u8::from(t));
    Ok(match op {
        BinOp::Pow => {
            if a < 0.0 && b.fract() != 0.0 {
                return Err("attempt to raise a negative number to a non-integer power".into());
            }
            a.powf(b)
        }
        BinOp::Mul => a * b,
        BinOp::Div | BinOp::Mod if b == 0.0 => return Err("division by zero".into()),
        BinOp::Div => a / b,
        BinOp::Mod => {
            let r = a % b;
            if r < 0.0 {
                r + b.abs()
            } else {
                r
            }
        }
        BinOp::Add => a + b,
        BinOp::Sub => a - b,
        BinOp::Eq => truth((a - b).abs() < TOLERANCE_EQUAL),
        BinOp::Ne => truth((a - b).abs() >= TOLERANCE_EQUAL),
        BinOp::Gt => truth(a > b),
        BinOp::Ge => truth(a >= b),
        BinOp::Lt => truth(a < b),
        BinOp::Le => truth(a <= b),
        BinOp::And => truth(a != 0.0 && b != 0.0),
        BinOp::Or => truth(a != 0.0 || b != 0.0),
        BinOp::Xor => truth((a != 0.0) != (b != 0.0)),
    })
}
