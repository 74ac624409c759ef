//! Reading a driver's cfg options the way Player's `ConfigFile` accessors do, but strictly: a
//! value that is not a number is an error naming the option, where `atof`/`atoi` would read 0.
//!
//! Units as Player's: a length or an angle written in the cfg is multiplied by the cfg's
//! `unit_length` (metres unless the cfg sets `cm` or `mm`) or `unit_angle` (degrees unless it
//! sets `radians`), which the block carries; a default is never scaled (Player returns it as
//! given, in metres and radians).

use player_server::DriverBlock;

use crate::error::Error;

/// Element `index` of option `key`, parsed; `None` when the option or the element is absent
/// (Player's tuple accessors return their default then).
fn element<T: std::str::FromStr>(
    block: &DriverBlock,
    key: &str,
    index: usize,
    what: &str,
) -> Result<Option<T>, Error> {
    let Some(text) = block.options.get(key).and_then(|v| v.get(index)) else {
        return Ok(None);
    };
    text.parse().map(Some).map_err(|_| Error::BadOption {
        option: key.to_string(),
        value: text.clone(),
        why: format!("not {what}"),
    })
}

/// Element `index` of option `key` as a number written in the cfg's `unit` (`what` it is,
/// for the error), returned in metres or radians.
fn scaled(
    block: &DriverBlock,
    key: &str,
    index: usize,
    what: &str,
    unit: f64,
) -> Result<Option<f64>, Error> {
    Ok(element::<f64>(block, key, index, what)?.map(|v| v * unit))
}

/// `ReadLength(key)`: a length, in metres.
pub fn length(block: &DriverBlock, key: &str) -> Result<Option<f64>, Error> {
    tuple_length(block, key, 0)
}

/// A length that must be given and positive, such as a map's resolution: `why` says what it
/// is for when it is missing, `unit` (e.g. `m/pixel`) what it measures when it is not positive.
pub fn positive_length(
    block: &DriverBlock,
    key: &'static str,
    why: &'static str,
    unit: &str,
) -> Result<f64, Error> {
    let value = length(block, key)?.ok_or(Error::MissingOption { option: key, why })?;
    if !(value > 0.0 && value.is_finite()) {
        return Err(Error::BadOption {
            option: key.to_string(),
            value: value.to_string(),
            why: format!("must be a positive length ({unit})"),
        });
    }
    Ok(value)
}

/// `ReadTupleLength(key, index)`: element `index` of a tuple of lengths.
pub fn tuple_length(block: &DriverBlock, key: &str, index: usize) -> Result<Option<f64>, Error> {
    scaled(block, key, index, "a length", block.units.length)
}

/// `ReadInt(key)`.
pub fn int(block: &DriverBlock, key: &str) -> Result<Option<i64>, Error> {
    element(block, key, 0, "an integer")
}

/// A switch written as an integer: on unless it is 0 (Player's `ReadInt(key, d) != 0`).
pub fn flag(block: &DriverBlock, key: &str) -> Result<Option<bool>, Error> {
    Ok(int(block, key)?.map(|v| v != 0))
}

/// `ReadFloat(key)`: a plain number.
pub fn float(block: &DriverBlock, key: &str) -> Result<Option<f64>, Error> {
    tuple_float(block, key, 0)
}

/// `ReadTupleFloat(key, index)`: element `index` of a tuple of plain numbers.
pub fn tuple_float(block: &DriverBlock, key: &str, index: usize) -> Result<Option<f64>, Error> {
    element(block, key, index, "a number")
}

/// `ReadAngle(key)`: an angle, in radians (written in degrees unless the cfg's `unit_angle`
/// says radians).
pub fn angle(block: &DriverBlock, key: &str) -> Result<Option<f64>, Error> {
    tuple_angle(block, key, 0)
}

/// `ReadTupleAngle(key, index)`: element `index` of a tuple of angles, in radians.
pub fn tuple_angle(block: &DriverBlock, key: &str, index: usize) -> Result<Option<f64>, Error> {
    scaled(block, key, index, "an angle", block.units.angle)
}

/// `ReadString(key)`.
pub fn string<'a>(block: &'a DriverBlock, key: &str) -> Option<&'a str> {
    block.option(key)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A block with `options` (values split on spaces, as a tuple).
    pub(crate) fn block(name: &str, options: &[(&str, &str)]) -> DriverBlock {
        crate::testing::block(name, &[], &[], options)
    }

    #[test]
    fn numbers_are_read_strictly() {
        let b = block(
            "x",
            &[("r", "0.25"), ("n", "3"), ("o", "1 -2.5 90"), ("bad", "5x")],
        );
        assert_eq!(length(&b, "r").unwrap(), Some(0.25));
        assert_eq!(length(&b, "none").unwrap(), None);
        assert_eq!(int(&b, "n").unwrap(), Some(3));
        assert_eq!(float(&b, "r").unwrap(), Some(0.25));
        assert_eq!(angle(&b, "n").unwrap(), Some(3f64.to_radians()));
        assert!(angle(&b, "bad").is_err());
        assert_eq!(tuple_length(&b, "o", 1).unwrap(), Some(-2.5));
        assert_eq!(tuple_length(&b, "o", 3).unwrap(), None);
        assert_eq!(
            length(&b, "bad").unwrap_err().to_string(),
            "option `bad` has an invalid value \"5x\": not a length"
        );
        assert!(int(&b, "r").is_err());
        assert_eq!(string(&b, "n"), Some("3"));
    }

    #[test]
    fn lengths_and_angles_follow_the_cfg_units_and_defaults_do_not() {
        let mut b = block("x", &[("r", "250"), ("n", "1.5"), ("o", "100 200 0.5")]);
        b.units = worldfile::Units {
            length: 0.001,
            angle: 1.0,
        };
        assert_eq!(length(&b, "r").unwrap(), Some(0.25));
        assert_eq!(tuple_length(&b, "o", 1).unwrap(), Some(0.2));
        assert_eq!(angle(&b, "n").unwrap(), Some(1.5));
        assert_eq!(tuple_angle(&b, "o", 2).unwrap(), Some(0.5));
        // Plain numbers are not lengths.
        assert_eq!(float(&b, "r").unwrap(), Some(250.0));
        assert_eq!(length(&b, "absent").unwrap(), None);
    }
}
