//! Typed reads of raw properties (stage-worldfile.md §6.2), with Stage's conversions.
//!
//! A read marks the property used. Where Stage silently turns junk into 0 (`atof("abc")`) or
//! exits (a tuple too short), we return an error that points at the value; where Stage reads a
//! prefix (`"1.2.3"` → 1.2) we keep Stage's value and warn. Stage 3 short forms (`pose [x y a]`,
//! `size [x y]`) are accepted with a warning.

use crate::color::{ColorSpec, Rgba};
use crate::document::{Document, EntityId, Property, Value};
use crate::error::{Error, ErrorKind, Warning};
use crate::numeric::{Prefix, float_overflows, int_overflows};

/// A 2D-plus-height pose `[x y z a]` in metres and radians (heading normalised to [-π, π]).
pub type Pose = [f64; 4];

/// Reads properties of one entity, collecting warnings.
pub struct Reader<'d, 'w> {
    doc: &'d Document,
    entity: EntityId,
    warnings: &'w mut Vec<Warning>,
}

impl<'d, 'w> Reader<'d, 'w> {
    /// A reader for `entity` of `doc`.
    pub fn new(doc: &'d Document, entity: EntityId, warnings: &'w mut Vec<Warning>) -> Self {
        Reader {
            doc,
            entity,
            warnings,
        }
    }

    /// The document.
    pub fn doc(&self) -> &'d Document {
        self.doc
    }

    /// The entity being read.
    pub fn entity(&self) -> EntityId {
        self.entity
    }

    /// Records a warning at a property.
    pub fn warn_at(&mut self, prop: &Property, message: impl Into<String>) {
        let loc = self.doc.loc(prop.loc);
        self.warnings.push(Warning::at(loc, message));
    }

    /// Records a warning at the entity.
    pub fn warn(&mut self, message: impl Into<String>) {
        let w = match self.doc.entity(self.entity).loc {
            Some(loc) => Warning::at(self.doc.loc(loc), message),
            None => Warning::general(message),
        };
        self.warnings.push(w);
    }

    /// Whether the property exists (does not mark it used).
    pub fn exists(&self, name: &str) -> bool {
        self.doc.property(self.entity, name).is_some()
    }

    /// The property, marked used. A tuple with no values counts as absent.
    pub fn prop(&self, name: &str) -> Option<&'d Property> {
        let p = self.doc.use_property(self.entity, name)?;
        if p.is_empty() { None } else { Some(p) }
    }

    /// The values of a property of the document being read.
    pub fn values(&self, p: &Property) -> &'d [Value] {
        self.doc.values(p)
    }

    /// The first value of a property [`Reader::prop`] returned (it has at least one).
    fn first(&self, p: &Property) -> &'d Value {
        &self.values(p)[0]
    }

    fn error(&self, kind: ErrorKind, value: &Value) -> Error {
        Error::at(kind, &self.doc.sources, value.loc, &value.text)
    }

    fn too_short(&self, p: &Property, needed: usize) -> Error {
        let name = self.doc.name(p);
        Error::at(
            ErrorKind::TupleTooShort {
                name: name.to_string(),
                needed,
                found: p.values.len,
            },
            &self.doc.sources,
            p.loc,
            name,
        )
    }

    /// `atof` of one value, as an error if there is no number and a warning if there is junk.
    #[inline]
    fn number(&mut self, p: &Property, v: &Value) -> Result<f64, Error> {
        match v.float() {
            // the usual case, kept apart from the messages
            Some(n) if n.complete && n.value.is_finite() => Ok(n.value),
            parsed => {
                if float_overflows(&v.text) {
                    let msg = format!(
                        "`{}` value `{}` is beyond the largest double: read as {} (as Stage's \
                         atof reads it), which no size, pose or rate can use",
                        self.doc.name(p),
                        v.text,
                        parsed.map_or(f64::INFINITY, |n| n.value)
                    );
                    self.warn_at(p, msg);
                }
                self.prefix_value(p, v, parsed, false)
            }
        }
    }

    /// `atoi` of one value (a clean decimal such as `180.0` truncates silently, like Stage).
    #[inline]
    fn integer(&mut self, p: &Property, v: &Value) -> Result<i64, Error> {
        match v.int() {
            Some(n) if n.complete && n.value.unsigned_abs() < i64::MAX.unsigned_abs() => {
                Ok(n.value)
            }
            _ if int_overflows(&v.text) => Err(self.error(
                ErrorKind::IntegerOverflow {
                    name: self.doc.name(p).to_string(),
                    text: v.text.to_string(),
                },
                v,
            )),
            parsed => {
                let clean_float = v.float().is_some_and(|f| f.complete);
                self.prefix_value(p, v, parsed, clean_float)
            }
        }
    }

    /// The value C's `atof`/`atoi` read from `v` (`parsed`): an error when there is no number,
    /// a warning when text follows it, unless `quiet`.
    #[cold]
    fn prefix_value<T: Copy + std::fmt::Display>(
        &mut self,
        p: &Property,
        v: &Value,
        parsed: Option<Prefix<T>>,
        quiet: bool,
    ) -> Result<T, Error> {
        match parsed {
            Some(n) => {
                if !n.complete && !quiet {
                    let msg = format!(
                        "`{}` value `{}` is read as {} (the rest is ignored, as in Stage)",
                        self.doc.name(p),
                        v.text,
                        n.value
                    );
                    self.warn_at(p, msg);
                }
                Ok(n.value)
            }
            None => Err(self.error(
                ErrorKind::NotANumber {
                    name: self.doc.name(p).to_string(),
                    text: v.text.to_string(),
                },
                v,
            )),
        }
    }

    fn scale(&self, format: u8) -> f64 {
        match format {
            b'l' => self.doc.units.length,
            b'a' => self.doc.units.angle,
            _ => 1.0,
        }
    }

    /// A float multiplied by `scale` (1, the length unit or the angle unit).
    fn scaled(&mut self, name: &str, format: u8) -> Result<Option<f64>, Error> {
        let Some(p) = self.prop(name) else {
            return Ok(None);
        };
        let v = self.number(p, self.first(p))?;
        Ok(Some(v * self.scale(format)))
    }

    /// `ReadFloat`: raw float.
    pub fn float(&mut self, name: &str) -> Result<Option<f64>, Error> {
        self.scaled(name, b'f')
    }

    /// `ReadLength`: float times `unit_length`.
    pub fn length(&mut self, name: &str) -> Result<Option<f64>, Error> {
        self.scaled(name, b'l')
    }

    /// `ReadAngle`: float times `unit_angle` (degrees to radians by default).
    pub fn angle(&mut self, name: &str) -> Result<Option<f64>, Error> {
        self.scaled(name, b'a')
    }

    /// `ReadInt`.
    pub fn int(&mut self, name: &str) -> Result<Option<i64>, Error> {
        let Some(p) = self.prop(name) else {
            return Ok(None);
        };
        self.integer(p, self.first(p)).map(Some)
    }

    /// `ReadInt` as a flag (non-zero is true).
    pub fn flag(&mut self, name: &str) -> Result<Option<bool>, Error> {
        Ok(self.int(name)?.map(|v| v != 0))
    }

    /// `ReadString`: the raw text of the first value.
    pub fn string(&mut self, name: &str) -> Result<Option<String>, Error> {
        Ok(self.prop(name).map(|p| self.first(p).text.to_string()))
    }

    /// Every value's raw text (a scalar gives one string).
    pub fn strings(&mut self, name: &str) -> Result<Option<Vec<String>>, Error> {
        Ok(self
            .prop(name)
            .map(|p| self.values(p).iter().map(|v| v.text.to_string()).collect()))
    }

    /// A string that must be one of `options`; anything else warns and keeps the default, as
    /// Stage does.
    pub fn choice<T: Copy>(
        &mut self,
        name: &str,
        options: &[(&str, T)],
    ) -> Result<Option<T>, Error> {
        let Some(p) = self.prop(name) else {
            return Ok(None);
        };
        let text = &*self.first(p).text;
        match options.iter().find(|(n, _)| *n == text) {
            Some((_, v)) => Ok(Some(*v)),
            None => {
                let names: Vec<String> = options.iter().map(|(n, _)| format!("\"{n}\"")).collect();
                let msg = format!(
                    "`{name}` \"{text}\" is not one of {}; keeping the default, as Stage does",
                    names.join(", ")
                );
                self.warn_at(p, msg);
                Ok(None)
            }
        }
    }

    /// `ReadTuple` with float formats `f`, `l`, `a` (one letter per element).
    pub fn floats<const N: usize>(
        &mut self,
        name: &str,
        format: &str,
    ) -> Result<Option<[f64; N]>, Error> {
        debug_assert_eq!(format.len(), N);
        let Some(p) = self.tuple(name, N)? else {
            return Ok(None);
        };
        let values = self.values(p);
        let mut out = [0.0; N];
        for (i, f) in format.bytes().enumerate() {
            out[i] = self.number(p, &values[i])? * self.scale(f);
        }
        Ok(Some(out))
    }

    /// `ReadTuple` with integer formats `i`/`u`.
    pub fn ints<const N: usize>(&mut self, name: &str) -> Result<Option<[i64; N]>, Error> {
        let Some(p) = self.tuple(name, N)? else {
            return Ok(None);
        };
        let values = self.values(p);
        let mut out = [0; N];
        for (o, v) in out.iter_mut().zip(values) {
            *o = self.integer(p, v)?;
        }
        Ok(Some(out))
    }

    /// `ReadTuple` with string formats.
    pub fn string_tuple<const N: usize>(
        &mut self,
        name: &str,
    ) -> Result<Option<[String; N]>, Error> {
        let Some(p) = self.tuple(name, N)? else {
            return Ok(None);
        };
        let values = self.values(p);
        Ok(Some(std::array::from_fn(|i| values[i].text.to_string())))
    }

    /// The property `name` as a tuple of `n` values (`ReadTuple`): too few is an error, more
    /// than `n` a warning that the rest are ignored.
    fn tuple(&mut self, name: &str, n: usize) -> Result<Option<&'d Property>, Error> {
        let Some(p) = self.prop(name) else {
            return Ok(None);
        };
        if p.values.len < n {
            return Err(self.too_short(p, n));
        }
        self.warn_extra(p, n);
        Ok(Some(p))
    }

    fn warn_extra(&mut self, p: &Property, n: usize) {
        if p.values.len > n {
            let msg = format!(
                "`{}` has {} values; only the first {n} are used",
                self.doc.name(p),
                p.values.len
            );
            self.warn_at(p, msg);
        }
    }

    /// A pose `[x y z a]` (lengths and an angle, heading normalised). The Stage 3 form `[x y a]`
    /// is accepted as `[x y 0 a]` with a warning.
    pub fn pose(&mut self, name: &str) -> Result<Option<Pose>, Error> {
        Ok(self
            .raw_pose(name)?
            .map(|p| [p[0], p[1], p[2], pose::angle::normalize(p[3])]))
    }

    /// A pose as [`Reader::pose`] with the heading as written (Stage keeps ranger transducer
    /// headings unnormalised: `270` is reported as 4.712 rad, not −1.571).
    pub fn raw_pose(&mut self, name: &str) -> Result<Option<Pose>, Error> {
        let Some(p) = self.prop(name) else {
            return Ok(None);
        };
        let l = self.doc.units.length;
        let a = self.doc.units.angle;
        let values = self.values(p);
        let pose = if values.len() == 3 {
            let msg = format!(
                "`{name}` has 3 values: read as the Stage 3 form [x y heading] with z = 0 (Stage 4.1.1 would exit: a pose is [x y z heading])"
            );
            self.warn_at(p, msg);
            [
                self.number(p, &values[0])? * l,
                self.number(p, &values[1])? * l,
                0.0,
                self.number(p, &values[2])? * a,
            ]
        } else {
            if values.len() < 4 {
                return Err(self.too_short(p, 4));
            }
            self.warn_extra(p, 4);
            [
                self.number(p, &values[0])? * l,
                self.number(p, &values[1])? * l,
                self.number(p, &values[2])? * l,
                self.number(p, &values[3])? * a,
            ]
        };
        Ok(Some(pose))
    }

    /// A size `[x y z]` in lengths. The Stage 3 form `[x y]` keeps `default_z` with a warning.
    pub fn size(&mut self, name: &str, default_z: f64) -> Result<Option<[f64; 3]>, Error> {
        let Some(p) = self.prop(name) else {
            return Ok(None);
        };
        let l = self.doc.units.length;
        let values = self.values(p);
        if values.len() == 2 {
            let msg = format!(
                "`{name}` has 2 values: read as the Stage 3 form [x y] with z = {default_z} (Stage 4.1.1 would exit: a size is [x y z])"
            );
            self.warn_at(p, msg);
            return Ok(Some([
                self.number(p, &values[0])? * l,
                self.number(p, &values[1])? * l,
                default_z,
            ]));
        }
        self.floats::<3>(name, "lll")
    }

    /// A colour as `Color::Load` reads it: `color` (a name, `"random"`, or `""` = no change)
    /// takes precedence over `color_rgba [r g b a]`. Unknown names become red with a warning.
    pub fn color(&mut self, allow_random: bool) -> Result<Option<ColorSpec>, Error> {
        if self.exists("color") {
            let Some(p) = self.prop("color") else {
                return Ok(None);
            };
            let name = &*self.first(p).text;
            if name.is_empty() {
                return Ok(None);
            }
            if name == "random" && allow_random {
                return Ok(Some(ColorSpec::Random));
            }
            return Ok(Some(ColorSpec::Rgba(self.named_color(p, name))));
        }
        Ok(self
            .floats::<4>("color_rgba", "ffff")?
            .map(|[r, g, b, a]| ColorSpec::Rgba(Rgba { r, g, b, a })))
    }

    /// An X11 colour name, red with a warning when unknown.
    pub fn named_color(&mut self, p: &Property, name: &str) -> Rgba {
        match Rgba::from_x11_name(name) {
            Some(c) => c,
            None => {
                let msg = format!(
                    "unknown colour name \"{name}\" (names are exact, case-sensitive X11 names); using red as Stage does"
                );
                self.warn_at(p, msg);
                Rgba::RED
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lexer::Dialect;
    use crate::loader::{LoadOptions, parse_document};
    use std::path::Path;

    fn doc(src: &str) -> Document {
        parse_document(
            Path::new("t.world"),
            src.as_bytes().to_vec(),
            Dialect::World,
            &LoadOptions::default(),
        )
        .unwrap()
    }

    #[test]
    fn conversions_use_units() {
        let d = doc(
            "unit_length \"cm\"\nunit_angle \"radians\"\nm ( l 150 a 1.5 f 2 pose [ 100 200 0 4 ] )\n",
        );
        let mut w = Vec::new();
        let mut r = Reader::new(&d, 1, &mut w);
        assert_eq!(r.length("l").unwrap(), Some(1.5));
        assert_eq!(r.angle("a").unwrap(), Some(1.5));
        assert_eq!(r.float("f").unwrap(), Some(2.0));
        let pose = r.pose("pose").unwrap().unwrap();
        assert!((pose[0] - 1.0).abs() < 1e-12 && (pose[1] - 2.0).abs() < 1e-12);
        assert!((pose[3] - (4.0 - 2.0 * std::f64::consts::PI)).abs() < 1e-12);
        assert_eq!(r.float("missing").unwrap(), None);
    }

    #[test]
    fn degrees_by_default() {
        let d = doc("m ( a 90 )\n");
        let mut w = Vec::new();
        let mut r = Reader::new(&d, 1, &mut w);
        let a = r.angle("a").unwrap().unwrap();
        assert!((a - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn reads_mark_used() {
        let d = doc("m ( a 1 b 2 )\n");
        let mut w = Vec::new();
        let mut r = Reader::new(&d, 1, &mut w);
        r.int("a").unwrap();
        let unused = d.unused_property_warnings();
        assert_eq!(unused.len(), 1);
        assert!(unused[0].message.contains("`b`"), "{}", unused[0]);
    }

    #[test]
    fn short_tuple_is_an_error_with_location() {
        let d = doc("m (\n  size [ 1 ]\n)\n");
        let mut w = Vec::new();
        let mut r = Reader::new(&d, 1, &mut w);
        let e = r.size("size", 1.0).unwrap_err();
        assert_eq!(
            e.kind,
            ErrorKind::TupleTooShort {
                name: "size".into(),
                needed: 3,
                found: 1
            }
        );
        assert_eq!(e.location.as_ref().unwrap().to_string(), "t.world:2:3");
    }

    #[test]
    fn stage3_short_forms_warn() {
        let d = doc("m ( pose [ 1 2 90 ] size [ 3 4 ] )\n");
        let mut w = Vec::new();
        let mut r = Reader::new(&d, 1, &mut w);
        let pose = r.pose("pose").unwrap().unwrap();
        assert_eq!(pose[2], 0.0);
        assert!((pose[3] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(r.size("size", 0.7).unwrap(), Some([3.0, 4.0, 0.7]));
        assert_eq!(w.len(), 2);
    }

    #[test]
    fn non_numbers_are_errors_and_prefixes_warn() {
        let d = doc("m ( a \"abc\" b 1.2.3 c \"1e3\" n 180.0 )\n");
        let mut w = Vec::new();
        {
            let mut r = Reader::new(&d, 1, &mut w);
            let e = r.float("a").unwrap_err();
            assert!(matches!(e.kind, ErrorKind::NotANumber { .. }));
            assert_eq!(r.float("b").unwrap(), Some(1.2));
        }
        assert_eq!(w.len(), 1);
        {
            let mut r = Reader::new(&d, 1, &mut w);
            assert_eq!(r.float("c").unwrap(), Some(1000.0));
            assert_eq!(r.int("n").unwrap(), Some(180));
        }
        assert_eq!(w.len(), 1);
    }

    #[test]
    fn colours() {
        let d = doc(
            "a ( color \"blue\" color_rgba [ 0 1 0 1 ] ) b ( color_rgba [ 0 1 0 0.5 ] ) c ( color \"nosuch\" ) d ( color \"random\" ) e ( color \"\" )\n",
        );
        let mut w = Vec::new();
        assert_eq!(
            Reader::new(&d, 1, &mut w).color(true).unwrap(),
            Some(ColorSpec::Rgba(Rgba::rgb(0.0, 0.0, 1.0)))
        );
        assert_eq!(
            Reader::new(&d, 2, &mut w).color(true).unwrap(),
            Some(ColorSpec::Rgba(Rgba {
                r: 0.0,
                g: 1.0,
                b: 0.0,
                a: 0.5
            }))
        );
        assert_eq!(
            Reader::new(&d, 3, &mut w).color(true).unwrap(),
            Some(ColorSpec::Rgba(Rgba::RED))
        );
        assert_eq!(w.len(), 1);
        assert_eq!(
            Reader::new(&d, 4, &mut w).color(true).unwrap(),
            Some(ColorSpec::Random)
        );
        assert_eq!(Reader::new(&d, 5, &mut w).color(true).unwrap(), None);
    }
}
