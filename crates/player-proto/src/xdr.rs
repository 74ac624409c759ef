//! XDR building blocks with Player's (playerxdrgen.py's) rules.
//!
//! * every scalar is big-endian; 8- and 16-bit integers are widened to a 4-byte word;
//! * variable arrays carry two equal length words: the struct's `x_count` member, then the XDR
//!   length prefix; arrays of 8-bit types are byte-packed and zero-padded to 4 bytes;
//! * fixed arrays without a count are exactly N elements with no length word.
//!
//! The decoder is strict: it accepts exactly what an XDR encoder produces (zero/sign extension,
//! zero padding, equal length words). libplayerc and libplayerc++ always produce that, and
//! strictness makes `encode(decode(bytes)) == bytes` hold for every accepted body.

use std::borrow::Cow;
use std::fmt;

use crate::error::{Error, Problem};
use crate::interface::InterfaceCode;
use crate::value::{Value, member};

/// A cursor over one message body. Never reads past the end; every shortfall is an error.
#[derive(Clone, Debug)]
pub struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    /// Starts reading at the first byte of `buf`.
    pub fn new(buf: &'a [u8]) -> Self {
        Reader { buf, pos: 0 }
    }

    /// Bytes not yet consumed.
    pub fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }

    /// True once every byte has been consumed.
    pub fn is_empty(&self) -> bool {
        self.remaining() == 0
    }

    /// Bytes consumed so far.
    pub fn position(&self) -> usize {
        self.pos
    }

    pub(crate) fn take(&mut self, n: usize) -> Result<&'a [u8], Error> {
        if n > self.remaining() {
            return Err(Error::malformed(Problem::Truncated {
                needed: n,
                available: self.remaining(),
            }));
        }
        let bytes = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(bytes)
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], Error> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N)?);
        Ok(out)
    }

    /// One 4-byte big-endian word.
    pub fn word(&mut self) -> Result<u32, Error> {
        self.array::<4>().map(u32::from_be_bytes)
    }

    /// One 8-byte big-endian hyper.
    pub fn hyper(&mut self) -> Result<u64, Error> {
        self.array::<8>().map(u64::from_be_bytes)
    }

    /// `n` raw bytes followed by zero padding to a multiple of 4 (XDR opaque data).
    pub fn opaque(&mut self, n: usize) -> Result<&'a [u8], Error> {
        let data = self.take(n)?;
        let pad = self.take(pad_len(n))?;
        if pad.iter().any(|&b| b != 0) {
            return Err(Error::malformed(Problem::NonZeroPadding));
        }
        Ok(data)
    }

    /// Reads the `x_count` member and the XDR length prefix of a variable array, and checks them
    /// against each other, against the C array's capacity and against the bytes left — all before
    /// the caller allocates anything.
    pub fn array_len(&mut self, max: Option<usize>, min_elem_size: usize) -> Result<usize, Error> {
        let count = self.word()?;
        let prefix = self.word()?;
        if prefix != count {
            return Err(Error::malformed(Problem::LengthMismatch { count, prefix }));
        }
        if let Some(max) = max {
            if count as usize > max {
                return Err(Error::malformed(Problem::CountAboveMax { count, max }));
            }
        }
        let needed = u64::from(count) * min_elem_size.max(1) as u64;
        if needed > self.remaining() as u64 {
            return Err(Error::malformed(Problem::CountBeyondBody {
                count,
                needed,
                available: self.remaining(),
            }));
        }
        Ok(count as usize)
    }
}

/// Zero bytes that follow `n` opaque bytes to reach a multiple of 4.
pub const fn pad_len(n: usize) -> usize {
    (4 - n % 4) % 4
}

/// Writes the two length words of a variable array (count member, then XDR prefix).
fn put_len(out: &mut Vec<u8>, len: usize) -> Result<(), Error> {
    let n = u32::try_from(len).map_err(|_| Error::TooLong {
        at: Default::default(),
        len,
        max: u32::MAX as usize,
    })?;
    out.extend_from_slice(&n.to_be_bytes());
    out.extend_from_slice(&n.to_be_bytes());
    Ok(())
}

/// Writes raw bytes plus zero padding (XDR opaque data).
fn put_opaque(out: &mut Vec<u8>, bytes: &[u8]) {
    out.extend_from_slice(bytes);
    out.extend_from_slice(&[0u8; 3][..pad_len(bytes.len())]);
}

/// A type with Player's XDR encoding: every member type of every message struct.
///
/// The struct declarations (`xdr_struct!`) build each struct's implementation from its members',
/// so encoder, decoder and field-map view all come from one description.
pub trait Xdr: Sized + Clone + fmt::Debug + 'static {
    /// The fewest bytes an encoding can take; bounds array allocations before decoding them.
    const MIN_SIZE: usize;

    /// Appends the XDR encoding.
    fn encode(&self, out: &mut Vec<u8>) -> Result<(), Error>;

    /// Reads one value, consuming exactly its encoding.
    fn decode(r: &mut Reader<'_>) -> Result<Self, Error>;

    /// The field-map view (C member names, `*_count` members included in structs).
    fn to_value(&self) -> Value;

    /// Builds a value from its field-map view.
    fn from_value(v: &Value) -> Result<Self, Error>;

    /// Adds this value as member `name` of a struct's field map. Arrays with a count member add
    /// `name_count` first, as the C struct declares it.
    fn put_member(&self, name: &str, out: &mut Vec<(String, Value)>) {
        out.push((name.to_owned(), self.to_value()));
    }

    /// Reads member `name` from a struct's field map (the inverse of [`Xdr::put_member`]).
    fn take_member(name: &str, members: &[(String, Value)]) -> Result<Self, Error> {
        Self::from_value(member(members, name)?)
    }

    /// Decodes `n` consecutive elements (the body of an `xdr_array`). Scalars override this
    /// with a bulk conversion; `n` has already been checked against the bytes left.
    fn decode_many(r: &mut Reader<'_>, n: usize) -> Result<Vec<Self>, Error> {
        let mut items = Vec::with_capacity(n);
        for _ in 0..n {
            items.push(Self::decode(r)?);
        }
        Ok(items)
    }

    /// Encodes consecutive elements (the body of an `xdr_array`).
    fn encode_many(items: &[Self], out: &mut Vec<u8>) -> Result<(), Error> {
        items.iter().try_for_each(|item| item.encode(out))
    }

    /// A proptest strategy over every value (the generated round-trip tests use it).
    #[cfg(test)]
    fn arbitrary() -> proptest::strategy::BoxedStrategy<Self>;
}

/// Implements [`Xdr`] and [`Elem`] for a 4- or 8-byte scalar: `$from`/`$to` convert between
/// the value and its big-endian bytes, `$value`/`$parse` between the value and its field-map
/// view. Arrays convert in bulk: one bounds check per array instead of one per element, which
/// lets the compiler vectorise the byte swapping (ranges, images of floats).
macro_rules! fixed_scalar {
    (
        $t:ty, $size:literal, $from:expr, $to:expr,
        value: |$x:ident| $value:expr,
        parse: |$v:ident| $parse:expr,
        arbitrary: $arb:expr $(,)?
    ) => {
        impl Xdr for $t {
            const MIN_SIZE: usize = $size;
            fn encode(&self, out: &mut Vec<u8>) -> Result<(), Error> {
                out.extend_from_slice(&$to(*self));
                Ok(())
            }
            fn decode(r: &mut Reader<'_>) -> Result<Self, Error> {
                r.array::<$size>().map($from)
            }
            fn to_value(&self) -> Value {
                let $x = *self;
                $value
            }
            fn from_value($v: &Value) -> Result<Self, Error> {
                $parse
            }
            fn decode_many(r: &mut Reader<'_>, n: usize) -> Result<Vec<Self>, Error> {
                let len = n.checked_mul($size).ok_or_else(|| {
                    Error::malformed(Problem::Truncated {
                        needed: usize::MAX,
                        available: r.remaining(),
                    })
                })?;
                let bytes = r.take(len)?;
                Ok(bytes
                    .chunks_exact($size)
                    .map(|c| {
                        let mut word = [0u8; $size];
                        word.copy_from_slice(c);
                        $from(word)
                    })
                    .collect())
            }
            fn encode_many(items: &[Self], out: &mut Vec<u8>) -> Result<(), Error> {
                let start = out.len();
                out.resize(start + items.len() * $size, 0);
                for (dst, item) in out[start..].chunks_exact_mut($size).zip(items) {
                    dst.copy_from_slice(&$to(*item));
                }
                Ok(())
            }
            #[cfg(test)]
            fn arbitrary() -> BoxedStrategy<Self> {
                $arb.boxed()
            }
        }
        impl Elem for $t {}
    };
}

/// Arrays that carry a `*_count` member, optionally bounded by a fixed C array size
/// (`driver_name[64]`, `devices[4096]`, ...).
pub trait Counted: Xdr {
    /// Elements (or bytes) present.
    fn count(&self) -> usize;

    /// Decodes with the fixed array's capacity as the maximum count.
    fn decode_max(r: &mut Reader<'_>, max: usize) -> Result<Self, Error>;

    /// Encodes, refusing (never truncating) more than `max` elements.
    fn encode_max(&self, max: usize, out: &mut Vec<u8>) -> Result<(), Error> {
        if self.count() > max {
            return Err(Error::TooLong {
                at: Default::default(),
                len: self.count(),
                max,
            });
        }
        self.encode(out)
    }

    /// A strategy producing at most `max` elements.
    #[cfg(test)]
    fn arbitrary_max(max: usize) -> proptest::strategy::BoxedStrategy<Self>;
}

/// Types encoded element by element in `xdr_array`/`xdr_vector` (everything but 8-bit types,
/// which are byte-packed instead).
pub trait Elem: Xdr {}

/// A message struct declared with `xdr_struct!`.
pub trait XdrStruct: Xdr {
    /// The upstream C type name, e.g. `player_position2d_cmd_vel_t`.
    const C_NAME: &'static str;
}

#[cfg(test)]
use proptest::prelude::*;

/// Implements [`Xdr`] for a widened 8/16-bit integer.
macro_rules! widened {
    ($t:ty, $c:literal, |$w:ident| $widen:expr, $arb:expr) => {
        impl Xdr for $t {
            const MIN_SIZE: usize = 4;
            fn encode(&self, out: &mut Vec<u8>) -> Result<(), Error> {
                // Zero-extends unsigned and sign-extends signed types, as xdr_u_char/xdr_char do.
                out.extend_from_slice(&(i64::from(*self) as u32).to_be_bytes());
                Ok(())
            }
            fn decode(r: &mut Reader<'_>) -> Result<Self, Error> {
                let $w = r.word()?;
                <$t>::try_from($widen)
                    .map_err(|_| Error::malformed(Problem::NotWidened { word: $w, ty: $c }))
            }
            fn to_value(&self) -> Value {
                Value::Int(i64::from(*self))
            }
            fn from_value(v: &Value) -> Result<Self, Error> {
                let i = v.int_in(i64::from(<$t>::MIN), i64::from(<$t>::MAX), $c)?;
                Ok(i as $t)
            }
            #[cfg(test)]
            fn arbitrary() -> BoxedStrategy<Self> {
                $arb.boxed()
            }
        }
    };
}

// Unsigned words must be zero extensions, signed ones sign extensions of the narrow value.
widened!(u8, "uint8_t", |w| w, any::<u8>());
widened!(i8, "int8_t/char", |w| w as i32, any::<i8>());
widened!(u16, "uint16_t", |w| w, any::<u16>());
widened!(i16, "int16_t", |w| w as i32, any::<i16>());
impl Elem for u16 {}
impl Elem for i16 {}

fixed_scalar!(u32, 4, u32::from_be_bytes, u32::to_be_bytes,
    value: |x| Value::Int(i64::from(x)),
    parse: |v| Ok(v.int_in(0, i64::from(u32::MAX), "uint32_t")? as u32),
    arbitrary: any::<u32>(),
);
fixed_scalar!(i32, 4, i32::from_be_bytes, i32::to_be_bytes,
    value: |x| Value::Int(i64::from(x)),
    parse: |v| Ok(v.int_in(i64::from(i32::MIN), i64::from(i32::MAX), "int32_t")? as i32),
    arbitrary: any::<i32>(),
);

/// f32 → f64 keeping NaN payloads bit for bit (hardware conversion quiets signalling NaNs,
/// and a float member may hold any bits: libplayerc sends some uninitialised).
fn widen_f32(f: f32) -> f64 {
    if f.is_nan() {
        let bits = f.to_bits();
        let sign = u64::from(bits >> 31) << 63;
        f64::from_bits(sign | (0x7ff << 52) | (u64::from(bits & 0x007f_ffff) << 29))
    } else {
        f64::from(f)
    }
}

/// The inverse of [`widen_f32`] for values it produces.
fn narrow_f64(x: f64) -> f32 {
    if x.is_nan() {
        let bits = x.to_bits();
        let sign = ((bits >> 63) as u32) << 31;
        f32::from_bits(sign | (0xff << 23) | ((bits >> 29) as u32 & 0x007f_ffff))
    } else {
        x as f32
    }
}

fixed_scalar!(f32, 4, |w| f32::from_bits(u32::from_be_bytes(w)), |x: f32| x.to_bits().to_be_bytes(),
    value: |x| Value::Float(widen_f32(x)),
    parse: |v| {
        let x = v.number()?;
        let f = narrow_f64(x);
        // The vectors only hold exactly representable values; anything else is a mistake.
        if widen_f32(f).to_bits() != x.to_bits() {
            return Err(Error::value(format!(
                "{x} is not exactly representable as float"
            )));
        }
        Ok(f)
    },
    // Every bit pattern, NaN payloads included: the codec must carry them unchanged.
    arbitrary: any::<u32>().prop_map(f32::from_bits),
);
fixed_scalar!(f64, 8, |w| f64::from_bits(u64::from_be_bytes(w)), |x: f64| x.to_bits().to_be_bytes(),
    value: |x| Value::Float(x),
    parse: |v| v.number(),
    arbitrary: any::<u64>().prop_map(f64::from_bits),
);

impl Xdr for InterfaceCode {
    const MIN_SIZE: usize = 4;
    fn encode(&self, out: &mut Vec<u8>) -> Result<(), Error> {
        self.0.encode(out)
    }
    fn decode(r: &mut Reader<'_>) -> Result<Self, Error> {
        u16::decode(r).map(InterfaceCode)
    }
    fn to_value(&self) -> Value {
        self.0.to_value()
    }
    fn from_value(v: &Value) -> Result<Self, Error> {
        u16::from_value(v).map(InterfaceCode)
    }
    #[cfg(test)]
    fn arbitrary() -> BoxedStrategy<Self> {
        any::<u16>().prop_map(InterfaceCode).boxed()
    }
}

/// The field-map members of an array with a count member (`name_count`, then `name`):
/// [`Xdr::put_member`] and [`Xdr::take_member`] of every counted array's impl.
macro_rules! counted_members {
    () => {
        fn put_member(&self, name: &str, out: &mut Vec<(String, Value)>) {
            put_counted(name, self.len(), self.to_value(), out);
        }
        fn take_member(name: &str, members: &[(String, Value)]) -> Result<Self, Error> {
            take_counted(name, members)
        }
    };
}

/// Shared by the counted-array impls: `name_count` then `name`, as in the C struct.
fn put_counted(name: &str, count: usize, value: Value, out: &mut Vec<(String, Value)>) {
    out.push((format!("{name}_count"), Value::Int(count as i64)));
    out.push((name.to_owned(), value));
}

/// Reads `name` and checks `name_count` (when present) against its length.
fn take_counted<T: Counted>(name: &str, members: &[(String, Value)]) -> Result<T, Error> {
    let value = T::from_value(member(members, name)?)?;
    if let Some(count) = members
        .iter()
        .find(|(n, _)| n.strip_suffix("_count") == Some(name))
        .map(|(_, v)| v)
    {
        let count = count.int_in(0, i64::from(u32::MAX), "uint32_t")?;
        if count as usize != value.count() {
            return Err(Error::value(format!(
                "`{name}_count` is {count} but `{name}` has {} elements",
                value.count()
            )));
        }
    }
    Ok(value)
}

/// Element-wise variable array (`xdr_array`): `T *x` or `T x[N]` with an `x_count` member.
impl<T: Elem> Xdr for Vec<T> {
    const MIN_SIZE: usize = 8;
    fn encode(&self, out: &mut Vec<u8>) -> Result<(), Error> {
        put_len(out, self.len())?;
        T::encode_many(self, out)
    }
    fn decode(r: &mut Reader<'_>) -> Result<Self, Error> {
        decode_elems(r, None)
    }
    fn to_value(&self) -> Value {
        Value::List(self.iter().map(Xdr::to_value).collect())
    }
    fn from_value(v: &Value) -> Result<Self, Error> {
        v.list()?.iter().map(T::from_value).collect()
    }
    counted_members!();
    #[cfg(test)]
    fn arbitrary() -> BoxedStrategy<Self> {
        Self::arbitrary_max(5)
    }
}

fn decode_elems<T: Elem>(r: &mut Reader<'_>, max: Option<usize>) -> Result<Vec<T>, Error> {
    let n = r.array_len(max, T::MIN_SIZE)?;
    // `n` is bounded by the bytes actually received, so the allocation is too.
    T::decode_many(r, n)
}

impl<T: Elem> Counted for Vec<T> {
    fn count(&self) -> usize {
        self.len()
    }
    fn decode_max(r: &mut Reader<'_>, max: usize) -> Result<Self, Error> {
        decode_elems(r, Some(max))
    }
    #[cfg(test)]
    fn arbitrary_max(max: usize) -> BoxedStrategy<Self> {
        proptest::collection::vec(T::arbitrary(), 0..=max.min(5)).boxed()
    }
}

/// Implements [`Xdr`] and [`Counted`] for a byte-packed array of an 8-bit type (`xdr_bytes`):
/// a length word, one byte per element, zero padding. `$bytes` gives the slice's wire bytes,
/// `$elems` the elements of received bytes, `$min..=$max` bounds the field-map integers.
macro_rules! byte_packed {
    (
        $t:ty, $c:literal, $min:literal..=$max:literal,
        bytes: |$s:ident| $bytes:expr,
        elems: |$b:ident| $elems:expr $(,)?
    ) => {
        impl Xdr for Vec<$t> {
            const MIN_SIZE: usize = 8;
            fn encode(&self, out: &mut Vec<u8>) -> Result<(), Error> {
                put_len(out, self.len())?;
                let $s: &[$t] = self;
                put_opaque(out, &$bytes);
                Ok(())
            }
            fn decode(r: &mut Reader<'_>) -> Result<Self, Error> {
                let n = r.array_len(None, 1)?;
                let $b = r.opaque(n)?;
                Ok($elems)
            }
            fn to_value(&self) -> Value {
                Value::List(self.iter().map(|&e| Value::Int(i64::from(e))).collect())
            }
            fn from_value(v: &Value) -> Result<Self, Error> {
                v.list()?
                    .iter()
                    .map(|e| e.int_in($min, $max, $c).map(|e| e as $t))
                    .collect()
            }
            counted_members!();
            #[cfg(test)]
            fn arbitrary() -> BoxedStrategy<Self> {
                Self::arbitrary_max(13)
            }
        }

        impl Counted for Vec<$t> {
            fn count(&self) -> usize {
                self.len()
            }
            fn decode_max(r: &mut Reader<'_>, max: usize) -> Result<Self, Error> {
                let n = r.array_len(Some(max), 1)?;
                let $b = r.opaque(n)?;
                Ok($elems)
            }
            #[cfg(test)]
            fn arbitrary_max(max: usize) -> BoxedStrategy<Self> {
                proptest::collection::vec(any::<$t>(), 0..=max.min(13)).boxed()
            }
        }
    };
}

// Images, intensities, bumper states, raw values: the bytes as they are.
byte_packed!(u8, "uint8_t", 0..=255,
    bytes: |s| Cow::Borrowed(s),
    elems: |b| b.to_vec(),
);
// Map cells (-1 free, 0 unknown, +1 occupied): two's complement bytes.
byte_packed!(i8, "int8_t", -128..=127,
    bytes: |s| Cow::<[u8]>::Owned(s.iter().map(|&c| c as u8).collect()),
    elems: |b| b.iter().map(|&b| b as i8).collect(),
);

/// Fixed array without a count member (`xdr_vector`): exactly N elements, no length word.
impl<T: Elem + Default + Copy, const N: usize> Xdr for [T; N] {
    const MIN_SIZE: usize = N * T::MIN_SIZE;
    fn encode(&self, out: &mut Vec<u8>) -> Result<(), Error> {
        self.iter().try_for_each(|e| e.encode(out))
    }
    fn decode(r: &mut Reader<'_>) -> Result<Self, Error> {
        let mut items = [T::default(); N];
        for item in &mut items {
            *item = T::decode(r)?;
        }
        Ok(items)
    }
    fn to_value(&self) -> Value {
        Value::List(self.iter().map(Xdr::to_value).collect())
    }
    fn from_value(v: &Value) -> Result<Self, Error> {
        let list = v.list()?;
        if list.len() != N {
            return Err(Error::value(format!(
                "expected exactly {N} elements, found {}",
                list.len()
            )));
        }
        let mut items = [T::default(); N];
        for (item, v) in items.iter_mut().zip(list) {
            *item = T::from_value(v)?;
        }
        Ok(items)
    }
    #[cfg(test)]
    fn arbitrary() -> BoxedStrategy<Self> {
        proptest::collection::vec(T::arbitrary(), N)
            .prop_map(|v| {
                let mut items = [T::default(); N];
                items.copy_from_slice(&v);
                items
            })
            .boxed()
    }
}

/// A `char` array with a count member: the exact bytes on the wire.
///
/// libplayerc counts the terminating NUL (`count = strlen + 1`) and several client code paths
/// rely on it being there, so [`Text::new`] appends it; [`Text::empty`] is the count-0 form
/// clients send in requests. Bytes are kept as received (they need not be UTF-8).
#[derive(Clone, Default, PartialEq, Eq, Hash)]
pub struct Text(Vec<u8>);

impl Text {
    /// `s` followed by a NUL, as libplayerc and upstream servers send strings.
    pub fn new(s: &str) -> Text {
        let mut bytes = Vec::with_capacity(s.len() + 1);
        bytes.extend_from_slice(s.as_bytes());
        bytes.push(0);
        Text(bytes)
    }

    /// No bytes at all (count 0), as clients send `driver_name` in DEV requests.
    pub fn empty() -> Text {
        Text(Vec::new())
    }

    /// Exactly these bytes on the wire (no NUL added).
    pub fn from_bytes(bytes: Vec<u8>) -> Text {
        Text(bytes)
    }

    /// The counted bytes, NUL included if it was sent.
    pub fn as_bytes(&self) -> &[u8] {
        &self.0
    }

    /// The count member's value.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// True for the count-0 form.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The text up to the first NUL, as a C reader would see it (invalid UTF-8 replaced).
    pub fn to_str_lossy(&self) -> Cow<'_, str> {
        let end = self.0.iter().position(|&b| b == 0).unwrap_or(self.0.len());
        String::from_utf8_lossy(&self.0[..end])
    }
}

impl From<&str> for Text {
    fn from(s: &str) -> Text {
        Text::new(s)
    }
}

impl fmt::Debug for Text {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Text(\"{}\")", self.0.escape_ascii())
    }
}

impl Xdr for Text {
    const MIN_SIZE: usize = 8;
    fn encode(&self, out: &mut Vec<u8>) -> Result<(), Error> {
        self.0.encode(out)
    }
    fn decode(r: &mut Reader<'_>) -> Result<Self, Error> {
        Vec::<u8>::decode(r).map(Text)
    }
    fn to_value(&self) -> Value {
        Value::Text(self.0.clone())
    }
    fn from_value(v: &Value) -> Result<Self, Error> {
        match v {
            Value::Text(bytes) => Ok(Text(bytes.clone())),
            other => Err(Error::value(format!(
                "expected text, found {}",
                other.kind()
            ))),
        }
    }
    counted_members!();
    #[cfg(test)]
    fn arbitrary() -> BoxedStrategy<Self> {
        Self::arbitrary_max(13)
    }
}

impl Counted for Text {
    fn count(&self) -> usize {
        self.len()
    }
    fn decode_max(r: &mut Reader<'_>, max: usize) -> Result<Self, Error> {
        Vec::<u8>::decode_max(r, max).map(Text)
    }
    #[cfg(test)]
    fn arbitrary_max(max: usize) -> BoxedStrategy<Self> {
        Vec::<u8>::arbitrary_max(max).prop_map(Text).boxed()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn enc<T: Xdr>(v: &T) -> Vec<u8> {
        let mut out = Vec::new();
        v.encode(&mut out).unwrap();
        out
    }

    #[test]
    fn widened_scalars_follow_xdr() {
        assert_eq!(enc(&200u8), [0, 0, 0, 0xc8]);
        assert_eq!(enc(&-1i8), [0xff; 4]);
        assert_eq!(enc(&65535u16), [0, 0, 0xff, 0xff]);
        assert_eq!(enc(&-2i16), [0xff, 0xff, 0xff, 0xfe]);
        assert_eq!(i8::decode(&mut Reader::new(&[0xff; 4])).unwrap(), -1);
        // A uint8 word with high bits set is not something an XDR encoder produces.
        let err = u8::decode(&mut Reader::new(&[0, 0, 1, 0])).unwrap_err();
        assert!(err.to_string().contains("not a valid uint8_t"), "{err}");
        // Nor is a char that was zero-extended instead of sign-extended.
        assert!(i8::decode(&mut Reader::new(&[0, 0, 0, 0xff])).is_err());
    }

    #[test]
    fn text_carries_its_nul_and_padding() {
        let t = Text::new("stage");
        assert_eq!(
            enc(&t),
            [
                0, 0, 0, 6, 0, 0, 0, 6, b's', b't', b'a', b'g', b'e', 0, 0, 0
            ]
        );
        assert_eq!(t.to_str_lossy(), "stage");
        assert_eq!(enc(&Text::empty()), [0u8; 8]);
    }

    #[test]
    fn array_counts_are_checked_before_allocating() {
        // count 0x40000000 doubles would need 8 GiB; only 8 bytes follow.
        let bytes = [0x40, 0, 0, 0, 0x40, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8];
        let err = Vec::<f64>::decode(&mut Reader::new(&bytes)).unwrap_err();
        assert!(matches!(
            err,
            Error::Malformed {
                problem: Problem::CountBeyondBody {
                    count: 0x4000_0000,
                    ..
                },
                ..
            }
        ));
        let err = Vec::<f64>::decode(&mut Reader::new(&[0, 0, 0, 1, 0, 0, 0, 2])).unwrap_err();
        assert!(err.to_string().contains("length word 2 differs"), "{err}");
        let err = Text::decode_max(&mut Reader::new(&[0, 0, 0, 65, 0, 0, 0, 65]), 64).unwrap_err();
        assert!(
            err.to_string().contains("count 65 exceeds the maximum 64"),
            "{err}"
        );
    }

    #[test]
    fn padding_must_be_zero_and_present() {
        let ok = [0, 0, 0, 1, 0, 0, 0, 1, 9, 0, 0, 0];
        assert_eq!(Vec::<u8>::decode(&mut Reader::new(&ok)).unwrap(), vec![9]);
        let mut bad = ok;
        bad[11] = 1;
        assert!(Vec::<u8>::decode(&mut Reader::new(&bad)).is_err());
        let err = Vec::<u8>::decode(&mut Reader::new(&ok[..10])).unwrap_err();
        assert!(err.to_string().contains("truncated"), "{err}");
    }

    #[test]
    fn encoding_refuses_overlong_fixed_arrays() {
        let mut out = Vec::new();
        let err = Text::from_bytes(vec![b'x'; 65])
            .encode_max(64, &mut out)
            .unwrap_err();
        assert!(matches!(
            err,
            Error::TooLong {
                len: 65,
                max: 64,
                ..
            }
        ));
    }

    #[test]
    fn fixed_vectors_have_no_length_word() {
        assert_eq!(enc(&[1.0f64, 2.0, 3.0]).len(), 24);
        let v = <[f64; 3]>::decode(&mut Reader::new(&enc(&[1.0f64, -2.0, 0.5]))).unwrap();
        assert_eq!(v, [1.0, -2.0, 0.5]);
    }
}
