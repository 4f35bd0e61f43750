//! Exact numeric slot values: `r + s·π` with rational `r`, `s`.
//!
//! Slots accept numbers and small expressions (`pi/2`, `-pi/2`, `2*pi/3`, `0.5`, `1e-3`),
//! kept exact: a decimal `0.375` is the rational 3/8, `pi/2` is `s = 1/2`. The symbolic engine
//! uses [`Exact::exact_cos_sin`] so that `cos(pi/2)` is exactly 0.

use num_bigint::BigInt;
use num_rational::BigRational;
use num_traits::{One, Signed, ToPrimitive, Zero};

/// An exact real number `rational + pi·π`.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Exact {
    /// The rational part `r`.
    pub rational: BigRational,
    /// The coefficient `s` of π.
    pub pi: BigRational,
}

impl Exact {
    /// Zero.
    #[must_use]
    pub fn zero() -> Self {
        Exact {
            rational: BigRational::zero(),
            pi: BigRational::zero(),
        }
    }

    /// A rational number.
    #[must_use]
    pub fn from_rational(r: BigRational) -> Self {
        Exact {
            rational: r,
            pi: BigRational::zero(),
        }
    }

    /// An integer.
    #[must_use]
    pub fn from_int(i: i64) -> Self {
        Self::from_rational(BigRational::from_integer(BigInt::from(i)))
    }

    /// The exact rational a finite `f64` stands for in its shortest decimal form
    /// (so the YAML number `0.375` is 3/8 and `0.1` is 1/10, not the binary neighbour).
    ///
    /// Returns `None` for NaN and infinities.
    #[must_use]
    pub fn from_f64(v: f64) -> Option<Self> {
        if !v.is_finite() {
            return None;
        }
        parse_decimal(&format!("{v:e}")).map(Self::from_rational)
    }

    /// Parses a slot expression: numbers, `pi`, `+ - * /`, parentheses, unary minus.
    ///
    /// Products and quotients must stay of the form `r + s·π` (no `pi*pi`, no division by
    /// an expression containing `pi`, no division by zero).
    ///
    /// # Errors
    /// A message saying what is wrong and where in the expression.
    pub fn parse(text: &str) -> Result<Self, String> {
        if text.len() > MAX_EXPR_LEN {
            return Err(format!(
                "the expression is {} characters long, more than the {MAX_EXPR_LEN} allowed",
                text.len()
            ));
        }
        let mut p = Parser {
            s: text.as_bytes(),
            i: 0,
            depth: 0,
        };
        let v = p.sum()?;
        p.skip_ws();
        if p.i != p.s.len() {
            return Err(format!(
                "unexpected `{}` at position {} of `{text}`",
                &text[p.i..],
                p.i + 1
            ));
        }
        Ok(v)
    }

    /// Whether the value is rational (no π part).
    #[must_use]
    pub fn is_rational(&self) -> bool {
        self.pi.is_zero()
    }

    /// Whether the value is exactly zero.
    #[must_use]
    pub fn is_zero(&self) -> bool {
        self.rational.is_zero() && self.pi.is_zero()
    }

    /// The nearest `f64`.
    #[must_use]
    pub fn to_f64(&self) -> f64 {
        let r = self.rational.to_f64().unwrap_or(f64::NAN);
        let s = self.pi.to_f64().unwrap_or(f64::NAN);
        r + s * core::f64::consts::PI
    }

    /// `(cos, sin)` as exact integers when the value is a multiple of π/2, else `None`
    /// (then cos and sin are irrational, and the engine keeps them as a symbol).
    #[must_use]
    pub fn exact_cos_sin(&self) -> Option<(i8, i8)> {
        if !self.rational.is_zero() {
            return None;
        }
        let twice = &self.pi * BigRational::from_integer(BigInt::from(2));
        if !twice.is_integer() {
            return None;
        }
        let k = (twice.to_integer() % BigInt::from(4) + BigInt::from(4)) % BigInt::from(4);
        match k.to_i64() {
            Some(0) => Some((1, 0)),
            Some(1) => Some((0, 1)),
            Some(2) => Some((-1, 0)),
            Some(3) => Some((0, -1)),
            _ => None,
        }
    }

    fn add(self, o: Exact) -> Exact {
        Exact {
            rational: self.rational + o.rational,
            pi: self.pi + o.pi,
        }
    }

    fn neg(self) -> Exact {
        Exact {
            rational: -self.rational,
            pi: -self.pi,
        }
    }
}

impl core::fmt::Display for Exact {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let rat = |r: &BigRational| {
            if r.is_integer() {
                r.numer().to_string()
            } else {
                format!("{}/{}", r.numer(), r.denom())
            }
        };
        match (self.rational.is_zero(), self.pi.is_zero()) {
            (_, true) => f.write_str(&rat(&self.rational)),
            (true, false) => {
                if self.pi.is_one() {
                    f.write_str("pi")
                } else if (-&self.pi).is_one() {
                    f.write_str("-pi")
                } else if self.pi.is_integer() {
                    write!(f, "{}*pi", self.pi.numer())
                } else if self.pi.numer().abs().is_one() {
                    let sign = if self.pi.is_negative() { "-" } else { "" };
                    write!(f, "{sign}pi/{}", self.pi.denom())
                } else {
                    write!(f, "{}*pi/{}", self.pi.numer(), self.pi.denom())
                }
            }
            (false, false) => write!(
                f,
                "{} + {}",
                rat(&self.rational),
                Exact::from_rational(BigRational::zero()).with_pi(&self.pi)
            ),
        }
    }
}

impl Exact {
    fn with_pi(mut self, pi: &BigRational) -> Self {
        self.pi = pi.clone();
        self
    }
}

/// Parses an unsigned decimal literal (`12`, `0.375`, `1.5e-3`, `2E4`) exactly.
fn parse_decimal(text: &str) -> Option<BigRational> {
    let (neg, body) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text.strip_prefix('+').unwrap_or(text)),
    };
    let (mant, exp) = match body.find(['e', 'E']) {
        Some(i) => (&body[..i], body[i + 1..].parse::<i64>().ok()?),
        None => (body, 0),
    };
    // Bounded before any arithmetic: no overflow, no huge power of ten.
    if exp.unsigned_abs() > u64::from(MAX_EXPONENT.unsigned_abs()) || mant.len() > MAX_EXPR_LEN {
        return None;
    }
    let exp = i32::try_from(exp).ok()?;
    let (int_part, frac_part) = match mant.find('.') {
        Some(i) => (&mant[..i], &mant[i + 1..]),
        None => (mant, ""),
    };
    if int_part.is_empty() && frac_part.is_empty() {
        return None;
    }
    if !int_part
        .bytes()
        .chain(frac_part.bytes())
        .all(|b| b.is_ascii_digit())
    {
        return None;
    }
    let digits = format!("{int_part}{frac_part}");
    let n: BigInt = digits.parse().ok()?;
    let scale = exp - i32::try_from(frac_part.len()).ok()?;
    let ten = BigInt::from(10);
    let mut r = BigRational::from_integer(n);
    if scale >= 0 {
        r *= BigRational::from_integer(num_traits::pow(ten, usize::try_from(scale).ok()?));
    } else {
        r /= BigRational::from_integer(num_traits::pow(ten, usize::try_from(-scale).ok()?));
    }
    Some(if neg { -r } else { r })
}

/// Deepest parenthesis nesting an expression may have.
pub const MAX_EXPR_DEPTH: usize = 32;
/// Longest expression text, in bytes.
pub const MAX_EXPR_LEN: usize = 256;
/// Largest decimal exponent of a literal (`1e300` is fine, `1e999999999` is refused before
/// any big-integer power is taken).
pub const MAX_EXPONENT: i32 = 400;

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
    /// Open parentheses around the current position.
    depth: usize,
}

impl Parser<'_> {
    fn skip_ws(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }

    fn peek(&mut self) -> Option<u8> {
        self.skip_ws();
        self.s.get(self.i).copied()
    }

    fn sum(&mut self) -> Result<Exact, String> {
        let mut v = self.product()?;
        loop {
            match self.peek() {
                Some(b'+') => {
                    self.i += 1;
                    v = v.add(self.product()?);
                }
                Some(b'-') => {
                    self.i += 1;
                    v = v.add(self.product()?.neg());
                }
                _ => return Ok(v),
            }
        }
    }

    fn product(&mut self) -> Result<Exact, String> {
        let mut v = self.unary()?;
        loop {
            match self.peek() {
                Some(b'*') => {
                    self.i += 1;
                    let w = self.unary()?;
                    v = if v.is_rational() {
                        Exact {
                            rational: &v.rational * &w.rational,
                            pi: &v.rational * &w.pi,
                        }
                    } else if w.is_rational() {
                        Exact {
                            rational: &v.rational * &w.rational,
                            pi: &v.pi * &w.rational,
                        }
                    } else {
                        return Err("a product of two terms with `pi` is not supported".into());
                    };
                }
                Some(b'/') => {
                    self.i += 1;
                    let w = self.unary()?;
                    if !w.is_rational() {
                        return Err("division by an expression with `pi` is not supported".into());
                    }
                    if w.rational.is_zero() {
                        return Err("division by zero".into());
                    }
                    v = Exact {
                        rational: &v.rational / &w.rational,
                        pi: &v.pi / &w.rational,
                    };
                }
                _ => return Ok(v),
            }
        }
    }

    fn unary(&mut self) -> Result<Exact, String> {
        // Signs are counted, not recursed into: `- - - … 1` costs no stack.
        let mut negative = false;
        loop {
            match self.peek() {
                Some(b'-') => negative = !negative,
                Some(b'+') => {}
                _ => break,
            }
            self.i += 1;
        }
        let v = self.atom()?;
        Ok(if negative { v.neg() } else { v })
    }

    fn atom(&mut self) -> Result<Exact, String> {
        match self.peek() {
            Some(b'(') => {
                self.i += 1;
                self.depth += 1;
                if self.depth > MAX_EXPR_DEPTH {
                    return Err(format!(
                        "parentheses nest deeper than {MAX_EXPR_DEPTH} levels at position {}",
                        self.i
                    ));
                }
                let v = self.sum()?;
                self.depth -= 1;
                if self.peek() != Some(b')') {
                    return Err("missing `)`".into());
                }
                self.i += 1;
                Ok(v)
            }
            Some(c) if c.is_ascii_alphabetic() => {
                let start = self.i;
                while self.i < self.s.len()
                    && (self.s[self.i].is_ascii_alphanumeric() || self.s[self.i] == b'_')
                {
                    self.i += 1;
                }
                let word = core::str::from_utf8(&self.s[start..self.i]).unwrap_or("");
                if word != "pi" && word.eq_ignore_ascii_case("pi") {
                    return Err(format!(
                        "`{word}`: names are exact and lowercase, write `pi`"
                    ));
                }
                if word == "pi" {
                    Ok(Exact {
                        rational: BigRational::zero(),
                        pi: BigRational::one(),
                    })
                } else {
                    Err(format!(
                        "`{word}` is not a number (only `pi` may appear inside an expression)"
                    ))
                }
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => {
                let start = self.i;
                while self.i < self.s.len()
                    && (self.s[self.i].is_ascii_digit() || self.s[self.i] == b'.')
                {
                    self.i += 1;
                }
                if self.i < self.s.len() && (self.s[self.i] == b'e' || self.s[self.i] == b'E') {
                    let save = self.i;
                    self.i += 1;
                    if self.i < self.s.len() && (self.s[self.i] == b'+' || self.s[self.i] == b'-') {
                        self.i += 1;
                    }
                    let digits = self.i;
                    while self.i < self.s.len() && self.s[self.i].is_ascii_digit() {
                        self.i += 1;
                    }
                    if digits == self.i {
                        self.i = save;
                    }
                }
                let lit = core::str::from_utf8(&self.s[start..self.i]).unwrap_or("");
                parse_decimal(lit)
                    .map(Exact::from_rational)
                    .ok_or_else(|| format!("`{lit}` is not a number"))
            }
            Some(_) => {
                // The character as written (the byte may start a multi-byte one).
                let rest = core::str::from_utf8(&self.s[self.i..]).unwrap_or("");
                let c = rest.chars().next().unwrap_or('?');
                Err(format!("unexpected `{c}` at position {}", self.i + 1))
            }
            None => Err("the expression ends too early".into()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(n: i64, d: i64) -> BigRational {
        BigRational::new(BigInt::from(n), BigInt::from(d))
    }

    #[test]
    fn bounds_depth_length_and_exponents_without_recursing_on_signs() {
        let deep = format!("{}1{}", "(".repeat(40), ")".repeat(40));
        assert!(Exact::parse(&deep).unwrap_err().contains("deeper than 32"));
        let ok = format!("{}1{}", "(".repeat(30), ")".repeat(30));
        assert_eq!(Exact::parse(&ok).unwrap(), Exact::from_int(1));
        assert_eq!(Exact::parse("- - -+- 2").unwrap(), Exact::from_int(2));
        assert!(Exact::parse(&"-".repeat(20_000))
            .unwrap_err()
            .contains("characters long"));
        assert!(Exact::parse("1e999999999").is_err());
        assert!(Exact::parse("1e300").is_ok());
        for e in [
            "1.5e-2147483648",
            "1e2147483647",
            "1e-9223372036854775808",
            "1e99999999999",
        ] {
            assert!(Exact::parse(e).is_err(), "{e}");
        }
        // A non-ASCII character is shown as written.
        let e = Exact::parse("0.5·2").unwrap_err();
        assert!(e.contains("`·2`") || e.contains("`·`"), "{e}");
        let e = Exact::parse("π/2").unwrap_err();
        assert!(e.contains("`π`"), "{e}");
    }

    #[test]
    fn parses_exact_forms() {
        assert_eq!(Exact::parse("0.375").unwrap().rational, q(3, 8));
        let e = Exact::parse("2*pi/3").unwrap();
        assert_eq!((e.rational.clone(), e.pi.clone()), (q(0, 1), q(2, 3)));
        assert_eq!(
            Exact::parse("-pi/2").unwrap().exact_cos_sin(),
            Some((0, -1))
        );
        assert_eq!(Exact::parse("pi").unwrap().exact_cos_sin(), Some((-1, 0)));
        assert_eq!(Exact::parse("2*pi/3").unwrap().exact_cos_sin(), None);
        assert_eq!(Exact::parse("1.5e-3").unwrap().rational, q(3, 2000));
        assert_eq!(
            Exact::parse("(1 + 1)*pi/4").unwrap().exact_cos_sin(),
            Some((0, 1))
        );
    }

    #[test]
    fn rejects_bad_expressions() {
        assert!(Exact::parse("pi*pi").is_err());
        assert!(Exact::parse("1/0").is_err());
        assert!(Exact::parse("2*x").is_err());
        assert!(Exact::parse("1 +").is_err());
        assert!(Exact::parse("").is_err());
    }

    #[test]
    fn from_f64_is_the_decimal() {
        assert_eq!(Exact::from_f64(0.1).unwrap().rational, q(1, 10));
        assert_eq!(
            Exact::from_f64(-1.793347906344996).unwrap().to_f64(),
            -1.793347906344996
        );
        assert!(Exact::from_f64(f64::NAN).is_none());
    }

    #[test]
    fn displays_readably() {
        assert_eq!(Exact::parse("-pi/2").unwrap().to_string(), "-pi/2");
        assert_eq!(Exact::parse("0.5").unwrap().to_string(), "1/2");
    }
}
