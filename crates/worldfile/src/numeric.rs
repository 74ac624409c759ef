//! C `atoi` / `atof` prefix semantics (stage-worldfile.md §6.4).
//!
//! Stage converts property text with `atoi`/`atof`, which read the longest numeric prefix and
//! ignore the rest: `"1.2.3"` is 1.2, `"+5"` is 5, `"1.9"` read as an int is 1. We keep those
//! values, but report whether the whole text was consumed (so callers can warn) and return `None`
//! when there is no numeric prefix at all (where Stage silently uses 0, we raise an error).

use nom::branch::alt;
use nom::bytes::complete::{tag_no_case, take_while1};
use nom::sequence::preceded;
use nom::{IResult, Parser};

/// A number read from the front of a text.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prefix<T> {
    /// The value of the numeric prefix.
    pub value: T,
    /// Whether the prefix was the whole text (after leading blanks).
    pub complete: bool,
}

fn is_c_space(c: char) -> bool {
    matches!(c, ' ' | '\t' | '\n' | '\r' | '\x0b' | '\x0c')
}

/// Length of the decimal number at the start of `b`: `digits [. digits*] | . digits`, then an
/// exponent if it has at least one digit. Scanned by hand: worldfiles are mostly numbers, and
/// this runs for every one of them.
fn decimal_len(b: &[u8]) -> Option<usize> {
    let digits = |from: usize| b[from..].iter().take_while(|c| c.is_ascii_digit()).count();
    let whole = digits(0);
    let mut end = whole;
    if b.get(end) == Some(&b'.') {
        let fraction = digits(end + 1);
        if whole == 0 && fraction == 0 {
            return None;
        }
        end += 1 + fraction;
    } else if whole == 0 {
        return None;
    }
    if matches!(b.get(end), Some(b'e' | b'E')) {
        let mut at = end + 1;
        if matches!(b.get(at), Some(b'+' | b'-')) {
            at += 1;
        }
        let exponent = digits(at);
        if exponent > 0 {
            end = at + exponent;
        }
    }
    Some(end)
}

fn special(input: &str) -> IResult<&str, &str> {
    alt((
        tag_no_case("infinity"),
        tag_no_case("inf"),
        tag_no_case("nan"),
    ))
    .parse(input)
}

fn hex(input: &str) -> IResult<&str, &str> {
    preceded(
        alt((tag_no_case("0x"),)),
        take_while1(|c: char| c.is_ascii_hexdigit()),
    )
    .parse(input)
}

/// C `atof`: optional blanks and sign, then a decimal (with exponent), `inf`/`nan` or hex integer.
pub fn atof(text: &str) -> Option<Prefix<f64>> {
    let (negative, after_sign) = split_sign(skip_c_spaces(text));
    let maybe_hex = matches!(after_sign.as_bytes(), [b'0', b'x' | b'X', _, ..]);
    let (rest, value) = if let Some((rest, h)) = maybe_hex.then(|| hex(after_sign).ok()).flatten() {
        // Very long hex runs overflow to infinity, as strtod does.
        let v = h.chars().fold(0f64, |acc, c| {
            acc * 16.0 + c.to_digit(16).unwrap_or(0) as f64
        });
        (rest, v)
    } else if let Some(len) = decimal_len(after_sign.as_bytes()) {
        // the recognised text is ASCII, so `len` is a character boundary
        let (d, rest) = after_sign.split_at(len);
        (rest, d.parse::<f64>().ok()?)
    } else if let Ok((rest, s)) = special(after_sign) {
        let v = if s.eq_ignore_ascii_case("nan") {
            f64::NAN
        } else {
            f64::INFINITY
        };
        (rest, v)
    } else {
        return None;
    };
    Some(Prefix {
        value: if negative { -value } else { value },
        complete: rest.is_empty(),
    })
}

/// C `atoi`: optional blanks and sign, then decimal digits. Saturates instead of overflowing.
pub fn atoi(text: &str) -> Option<Prefix<i64>> {
    let (negative, unsigned) = split_sign(skip_c_spaces(text));
    let digits = unsigned.bytes().take_while(u8::is_ascii_digit).count();
    if digits == 0 {
        return None;
    }
    let magnitude = unsigned.as_bytes()[..digits].iter().fold(0i64, |acc, d| {
        acc.saturating_mul(10).saturating_add(i64::from(d - b'0'))
    });
    Some(Prefix {
        value: if negative { -magnitude } else { magnitude },
        complete: digits == unsigned.len(),
    })
}

/// Whether the integer C's `atoi` reads from `text` is beyond what an `i64` holds (where
/// [`atoi`] saturates; glibc's `atoi` is `(int) strtol`, which makes such a number -1 or 0).
pub fn int_overflows(text: &str) -> bool {
    let (negative, unsigned) = split_sign(skip_c_spaces(text));
    let digits = unsigned.bytes().take_while(u8::is_ascii_digit);
    let limit = if negative {
        i64::MAX.unsigned_abs() + 1
    } else {
        i64::MAX.unsigned_abs()
    };
    let mut magnitude: u64 = 0;
    for d in digits {
        match magnitude
            .checked_mul(10)
            .and_then(|m| m.checked_add(u64::from(d - b'0')))
        {
            Some(m) if m <= limit => magnitude = m,
            _ => return true,
        }
    }
    false
}

/// Whether C's `atof` reads `text` as an infinity that is not written as one: a finite
/// number beyond `f64::MAX` (`1e999`, a long hex run), which `strtod` turns into ±inf with
/// ERANGE. `inf` and `infinity` written out are not overflows.
pub fn float_overflows(text: &str) -> bool {
    let (_, unsigned) = split_sign(skip_c_spaces(text));
    atof(text).is_some_and(|n| n.value.is_infinite())
        && !unsigned.starts_with(|c: char| c.eq_ignore_ascii_case(&'i'))
}

/// Whether `text` starts with a minus, and `text` without its sign (`+` or `-`), as C's
/// number conversions read one.
fn split_sign(text: &str) -> (bool, &str) {
    match text.as_bytes().first() {
        Some(b'-') => (true, &text[1..]),
        Some(b'+') => (false, &text[1..]),
        _ => (false, text),
    }
}

/// `text` without the leading blanks C's number conversions skip (all ASCII, so the cut is
/// a character boundary).
fn skip_c_spaces(text: &str) -> &str {
    let blanks = text
        .bytes()
        .take_while(|&b| is_c_space(char::from(b)))
        .count();
    &text[blanks..]
}

#[cfg(test)]
mod tests {
    use super::*;
    use nom::bytes::complete::take_while;
    use nom::character::complete::one_of;
    use nom::combinator::{opt, recognize};
    use nom::sequence::pair;

    fn digits(input: &str) -> IResult<&str, &str> {
        take_while1(|c: char| c.is_ascii_digit())(input)
    }

    /// The decimal recogniser written with parser combinators: the reference [`decimal_len`] is
    /// checked against.
    fn decimal(input: &str) -> IResult<&str, &str> {
        // digits [. digits*] | . digits, then an optional exponent that has at least one digit.
        let mantissa = alt((
            recognize(pair(
                digits,
                opt(pair(one_of("."), take_while(|c: char| c.is_ascii_digit()))),
            )),
            recognize(pair(one_of("."), digits)),
        ));
        let exponent = recognize((one_of("eE"), opt(one_of("+-")), digits));
        recognize(pair(mantissa, opt(exponent))).parse(input)
    }

    fn f(s: &str) -> Option<(f64, bool)> {
        atof(s).map(|p| (p.value, p.complete))
    }
    fn i(s: &str) -> Option<(i64, bool)> {
        atoi(s).map(|p| (p.value, p.complete))
    }

    #[test]
    fn atof_prefix_semantics() {
        assert_eq!(f("1.5"), Some((1.5, true)));
        assert_eq!(f("1.2.3"), Some((1.2, false)));
        assert_eq!(f("+5"), Some((5.0, true)));
        assert_eq!(f("-.5"), Some((-0.5, true)));
        assert_eq!(f("5."), Some((5.0, true)));
        assert_eq!(f("1e3"), Some((1000.0, true)));
        assert_eq!(f("1e"), Some((1.0, false)));
        assert_eq!(f("  7"), Some((7.0, true)));
        assert_eq!(f("0x10"), Some((16.0, true)));
        assert_eq!(f("1-2"), Some((1.0, false)));
        assert!(f("inf").unwrap().0.is_infinite());
        assert!(f("nan").unwrap().0.is_nan());
        assert_eq!(f("-"), None);
        assert_eq!(f("."), None);
        assert_eq!(f("abc"), None);
        assert_eq!(f(""), None);
    }

    /// `atoi` written with parser combinators: the reference the hand-written one is checked
    /// against.
    fn atoi_reference(text: &str) -> Option<Prefix<i64>> {
        let body = text.trim_start_matches(is_c_space);
        let (rest, (sign, ds)) = pair(opt(one_of::<_, _, nom::error::Error<&str>>("+-")), digits)
            .parse(body)
            .ok()?;
        let magnitude = ds.chars().fold(0i64, |acc, c| {
            acc.saturating_mul(10)
                .saturating_add(i64::from(c.to_digit(10).unwrap_or(0)))
        });
        let value = if sign == Some('-') {
            -magnitude
        } else {
            magnitude
        };
        Some(Prefix {
            value,
            complete: rest.is_empty(),
        })
    }

    proptest::proptest! {
        /// The hand-written `atoi` reads what the combinator one does.
        #[test]
        fn atoi_matches_the_grammar(text in "[ \t0-9+x.-]{0,24}") {
            proptest::prop_assert_eq!(atoi(&text), atoi_reference(&text));
        }

        /// The hand-written decimal scanner recognises what the combinator one does.
        #[test]
        fn decimal_scanner_matches_the_grammar(text in "[0-9.eE+x-]{0,8}") {
            let reference = decimal(&text).ok().map(|(rest, _)| text.len() - rest.len());
            proptest::prop_assert_eq!(decimal_len(text.as_bytes()), reference);
        }
    }

    #[test]
    fn atoi_prefix_semantics() {
        assert_eq!(i("42"), Some((42, true)));
        assert_eq!(i("1.9"), Some((1, false)));
        assert_eq!(i("-3"), Some((-3, true)));
        assert_eq!(i("+3x"), Some((3, false)));
        assert_eq!(i("abc"), None);
        assert_eq!(i("-"), None);
        assert_eq!(i("99999999999999999999999"), Some((i64::MAX, true)));
    }

    #[test]
    fn overflows_are_told_apart_from_big_numbers() {
        assert!(!int_overflows("9223372036854775807"));
        assert!(int_overflows("9223372036854775808"));
        assert!(!int_overflows("-9223372036854775808"));
        assert!(int_overflows("-9223372036854775809"));
        assert!(int_overflows(" +99999999999999999999999x"));
        assert!(!int_overflows("000000000000000000000000042"));
        assert!(!int_overflows("abc"));
        assert!(float_overflows("1e309"));
        assert!(float_overflows("-1e999"));
        assert!(float_overflows(&format!("0x{}", "f".repeat(300))));
        assert!(!float_overflows("1.7e308"));
        assert!(!float_overflows("inf"));
        assert!(!float_overflows("-Infinity"));
        assert!(!float_overflows("1e-999"));
        assert!(!float_overflows("nan"));
    }
}
