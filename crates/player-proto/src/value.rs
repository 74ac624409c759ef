//! A JSON-like view of message structs, keyed by the C member names.
//!
//! The conformance vectors describe every body as a nested map in C member order, `*_count`
//! members included. Generating this view from the same declaration as the codec lets tests
//! compare against the vectors directly, and lets tools such as a playerv-style viewer print any
//! message without per-struct code.

use std::fmt;

use crate::error::Error;

/// A struct, array or scalar of a Player message, as upstream's C structs hold it.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// Any integer member (8- to 32-bit, signed or unsigned), and array `*_count` members.
    Int(i64),
    /// A `float` (widened exactly) or `double` member.
    Float(f64),
    /// A `char` array: exactly the counted bytes, including the terminating NUL if sent.
    Text(Vec<u8>),
    /// An array (variable, or fixed without a count).
    List(Vec<Value>),
    /// A struct: members in declaration (= wire) order.
    Struct(Vec<(String, Value)>),
}

impl Value {
    /// The member named `name` of a struct value.
    pub fn get(&self, name: &str) -> Option<&Value> {
        match self {
            Value::Struct(members) => members.iter().find(|(n, _)| n == name).map(|(_, v)| v),
            _ => None,
        }
    }

    /// A struct's members, or an error naming what was found instead.
    pub(crate) fn members(&self) -> Result<&[(String, Value)], Error> {
        match self {
            Value::Struct(members) => Ok(members),
            other => Err(Error::value(format!(
                "expected a struct, found {}",
                other.kind()
            ))),
        }
    }

    /// A short name of the variant, for error messages.
    pub(crate) fn kind(&self) -> &'static str {
        match self {
            Value::Int(_) => "an integer",
            Value::Float(_) => "a float",
            Value::Text(_) => "text",
            Value::List(_) => "a list",
            Value::Struct(_) => "a struct",
        }
    }

    /// An integer within `min..=max`, or an error saying why not.
    pub(crate) fn int_in(&self, min: i64, max: i64, ty: &str) -> Result<i64, Error> {
        match self {
            Value::Int(i) if (min..=max).contains(i) => Ok(*i),
            Value::Int(i) => Err(Error::value(format!("{i} does not fit in {ty}"))),
            other => Err(Error::value(format!(
                "expected an integer for {ty}, found {}",
                other.kind()
            ))),
        }
    }

    /// A number as f64 (integers are accepted where a float is expected).
    pub(crate) fn number(&self) -> Result<f64, Error> {
        match self {
            Value::Float(f) => Ok(*f),
            Value::Int(i) => Ok(*i as f64),
            other => Err(Error::value(format!(
                "expected a number, found {}",
                other.kind()
            ))),
        }
    }

    /// A list's elements.
    pub(crate) fn list(&self) -> Result<&[Value], Error> {
        match self {
            Value::List(items) => Ok(items),
            other => Err(Error::value(format!(
                "expected a list, found {}",
                other.kind()
            ))),
        }
    }
}

impl fmt::Display for Value {
    /// A compact JSON-like rendering (text shown with escapes), for logs and tools.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Int(i) => write!(f, "{i}"),
            Value::Float(x) => write!(f, "{x:?}"),
            Value::Text(bytes) => write!(f, "\"{}\"", bytes.escape_ascii()),
            Value::List(items) => {
                f.write_str("[")?;
                for (i, item) in items.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    write!(f, "{item}")?;
                }
                f.write_str("]")
            }
            Value::Struct(members) => {
                f.write_str("{")?;
                for (i, (name, item)) in members.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    write!(f, "{name}: {item}")?;
                }
                f.write_str("}")
            }
        }
    }
}

/// Looks a member up in a struct's member list, for the generated `from_value` code.
pub(crate) fn member<'a>(members: &'a [(String, Value)], name: &str) -> Result<&'a Value, Error> {
    members
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, v)| v)
        .ok_or_else(|| Error::value(format!("missing member `{name}`")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_is_json_like() {
        let v = Value::Struct(vec![
            ("n_count".into(), Value::Int(3)),
            ("n".into(), Value::Text(b"r0\0".to_vec())),
            (
                "xs".into(),
                Value::List(vec![Value::Float(1.5), Value::Int(-2)]),
            ),
        ]);
        assert_eq!(v.to_string(), "{n_count: 3, n: \"r0\\x00\", xs: [1.5, -2]}");
        assert_eq!(v.get("n_count"), Some(&Value::Int(3)));
        assert_eq!(v.get("missing"), None);
    }

    #[test]
    fn range_checks_name_the_type() {
        let err = Value::Int(256).int_in(0, 255, "uint8_t").unwrap_err();
        assert!(
            err.to_string().contains("256 does not fit in uint8_t"),
            "{err}"
        );
        assert!(Value::Float(1.0).int_in(0, 1, "uint8_t").is_err());
        assert_eq!(Value::Int(7).number().unwrap(), 7.0);
    }
}
