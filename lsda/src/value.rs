//! Variable types and their values: the type codes LSTC's `lsda` defines (I1…I8, U1…U8, R4, R8
//! and LINK) and the decoding of a DATA record's bytes in the file's byte order.

use crate::header::{Endian, Header};

/// The type of a variable, by its code in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TypeId {
    I1,
    I2,
    I4,
    I8,
    U1,
    U2,
    U4,
    U8,
    R4,
    R8,
    /// A path to another variable (text), LSTC's LINK.
    Link,
}

impl TypeId {
    /// The type of code `code` (1…11), if there is one.
    pub fn from_code(code: i64) -> Option<TypeId> {
        use TypeId::*;
        Some(match code {
            1 => I1,
            2 => I2,
            3 => I4,
            4 => I8,
            5 => U1,
            6 => U2,
            7 => U4,
            8 => U8,
            9 => R4,
            10 => R8,
            11 => Link,
            _ => return None,
        })
    }

    pub fn code(self) -> u8 {
        use TypeId::*;
        match self {
            I1 => 1,
            I2 => 2,
            I4 => 3,
            I8 => 4,
            U1 => 5,
            U2 => 6,
            U4 => 7,
            U8 => 8,
            R4 => 9,
            R8 => 10,
            Link => 11,
        }
    }

    /// Bytes of one value.
    pub fn size(self) -> usize {
        use TypeId::*;
        match self {
            I1 | U1 | Link => 1,
            I2 | U2 => 2,
            I4 | U4 | R4 => 4,
            I8 | U8 | R8 => 8,
        }
    }

    /// `I4`, `R8`, …: the name LSTC's documentation uses.
    pub fn name(self) -> &'static str {
        use TypeId::*;
        match self {
            I1 => "I1",
            I2 => "I2",
            I4 => "I4",
            I8 => "I8",
            U1 => "U1",
            U2 => "U2",
            U4 => "U4",
            U8 => "U8",
            R4 => "R4",
            R8 => "R8",
            Link => "LINK",
        }
    }

    pub fn is_real(self) -> bool {
        matches!(self, TypeId::R4 | TypeId::R8)
    }
}

/// A variable's values, exactly as stored.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    I1(Vec<i8>),
    I2(Vec<i16>),
    I4(Vec<i32>),
    I8(Vec<i64>),
    U1(Vec<u8>),
    U2(Vec<u16>),
    U4(Vec<u32>),
    U8(Vec<u64>),
    R4(Vec<f32>),
    R8(Vec<f64>),
    /// The target path of a LINK.
    Link(Vec<u8>),
}

/// `N` bytes of each value of `data`, in `endian` order, turned into numbers by `f`.
fn chunks<const N: usize, T>(data: &[u8], endian: Endian, f: impl Fn([u8; N]) -> T) -> Vec<T> {
    data.chunks_exact(N)
        .map(|c| {
            let mut b = [0u8; N];
            b.copy_from_slice(c);
            if endian == Endian::Big {
                b.reverse();
            }
            f(b)
        })
        .collect()
}

impl Values {
    /// Decodes `data` (a whole number of values of type `t`) in the byte order of `h`.
    pub(crate) fn decode(h: &Header, t: TypeId, data: &[u8]) -> Values {
        let e = h.endian;
        match t {
            TypeId::I1 => Values::I1(data.iter().map(|&b| b as i8).collect()),
            TypeId::U1 => Values::U1(data.to_vec()),
            TypeId::Link => Values::Link(data.to_vec()),
            TypeId::I2 => Values::I2(chunks(data, e, i16::from_le_bytes)),
            TypeId::U2 => Values::U2(chunks(data, e, u16::from_le_bytes)),
            TypeId::I4 => Values::I4(chunks(data, e, i32::from_le_bytes)),
            TypeId::U4 => Values::U4(chunks(data, e, u32::from_le_bytes)),
            TypeId::I8 => Values::I8(chunks(data, e, i64::from_le_bytes)),
            TypeId::U8 => Values::U8(chunks(data, e, u64::from_le_bytes)),
            TypeId::R4 => Values::R4(chunks(data, e, f32::from_le_bytes)),
            TypeId::R8 => Values::R8(chunks(data, e, f64::from_le_bytes)),
        }
    }

    /// Appends the values' bytes in the byte order of `h`.
    pub(crate) fn encode(&self, h: &Header, out: &mut Vec<u8>) {
        fn put<const N: usize>(out: &mut Vec<u8>, e: Endian, mut b: [u8; N]) {
            if e == Endian::Big {
                b.reverse();
            }
            out.extend_from_slice(&b);
        }
        let e = h.endian;
        match self {
            Values::I1(v) => out.extend(v.iter().map(|&x| x as u8)),
            Values::U1(v) | Values::Link(v) => out.extend_from_slice(v),
            Values::I2(v) => v.iter().for_each(|x| put(out, e, x.to_le_bytes())),
            Values::U2(v) => v.iter().for_each(|x| put(out, e, x.to_le_bytes())),
            Values::I4(v) => v.iter().for_each(|x| put(out, e, x.to_le_bytes())),
            Values::U4(v) => v.iter().for_each(|x| put(out, e, x.to_le_bytes())),
            Values::I8(v) => v.iter().for_each(|x| put(out, e, x.to_le_bytes())),
            Values::U8(v) => v.iter().for_each(|x| put(out, e, x.to_le_bytes())),
            Values::R4(v) => v.iter().for_each(|x| put(out, e, x.to_le_bytes())),
            Values::R8(v) => v.iter().for_each(|x| put(out, e, x.to_le_bytes())),
        }
    }

    pub fn type_id(&self) -> TypeId {
        match self {
            Values::I1(_) => TypeId::I1,
            Values::I2(_) => TypeId::I2,
            Values::I4(_) => TypeId::I4,
            Values::I8(_) => TypeId::I8,
            Values::U1(_) => TypeId::U1,
            Values::U2(_) => TypeId::U2,
            Values::U4(_) => TypeId::U4,
            Values::U8(_) => TypeId::U8,
            Values::R4(_) => TypeId::R4,
            Values::R8(_) => TypeId::R8,
            Values::Link(_) => TypeId::Link,
        }
    }

    pub fn len(&self) -> usize {
        match self {
            Values::I1(v) => v.len(),
            Values::I2(v) => v.len(),
            Values::I4(v) => v.len(),
            Values::I8(v) => v.len(),
            Values::U1(v) | Values::Link(v) => v.len(),
            Values::U2(v) => v.len(),
            Values::U4(v) => v.len(),
            Values::U8(v) => v.len(),
            Values::R4(v) => v.len(),
            Values::R8(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every value as an `f64`: exact for reals and for integers up to 2^53 in size.
    pub fn to_f64(&self) -> Vec<f64> {
        match self {
            Values::I1(v) => v.iter().map(|&x| x as f64).collect(),
            Values::I2(v) => v.iter().map(|&x| x as f64).collect(),
            Values::I4(v) => v.iter().map(|&x| x as f64).collect(),
            Values::I8(v) => v.iter().map(|&x| x as f64).collect(),
            Values::U1(v) | Values::Link(v) => v.iter().map(|&x| x as f64).collect(),
            Values::U2(v) => v.iter().map(|&x| x as f64).collect(),
            Values::U4(v) => v.iter().map(|&x| x as f64).collect(),
            Values::U8(v) => v.iter().map(|&x| x as f64).collect(),
            Values::R4(v) => v.iter().map(|&x| x as f64).collect(),
            Values::R8(v) => v.clone(),
        }
    }

    /// Every value as an `i64`, for integer types (`None` for reals, and for a U8 above
    /// `i64::MAX`).
    pub fn to_i64(&self) -> Option<Vec<i64>> {
        Some(match self {
            Values::I1(v) => v.iter().map(|&x| x as i64).collect(),
            Values::I2(v) => v.iter().map(|&x| x as i64).collect(),
            Values::I4(v) => v.iter().map(|&x| x as i64).collect(),
            Values::I8(v) => v.clone(),
            Values::U1(v) | Values::Link(v) => v.iter().map(|&x| x as i64).collect(),
            Values::U2(v) => v.iter().map(|&x| x as i64).collect(),
            Values::U4(v) => v.iter().map(|&x| x as i64).collect(),
            Values::U8(v) => v.iter().map(|&x| i64::try_from(x).ok()).collect::<Option<_>>()?,
            Values::R4(_) | Values::R8(_) => return None,
        })
    }

    /// The values as text, one character per byte (how LS-DYNA stores titles, dates and
    /// versions: I1 arrays), for one-byte types; `None` for others.
    pub fn text(&self) -> Option<String> {
        let bytes: Vec<u8> = match self {
            Values::I1(v) => v.iter().map(|&x| x as u8).collect(),
            Values::U1(v) | Values::Link(v) => v.clone(),
            _ => return None,
        };
        Some(bytes.iter().map(|&b| b as char).collect())
    }

    /// A title or other text as LS-DYNA stores it (I1).
    pub fn from_text(s: &str) -> Values {
        Values::I1(s.bytes().map(|b| b as i8).collect())
    }
}

/// `data` (values of type `t`) decoded straight to `f64`, as [`Values::to_f64`] of
/// [`Values::decode`] gives them, without the typed vector between.
pub(crate) fn decode_f64(h: &Header, t: TypeId, data: &[u8]) -> Vec<f64> {
    let e = h.endian;
    match t {
        TypeId::R4 => chunks(data, e, |b| f32::from_le_bytes(b) as f64),
        TypeId::R8 => chunks(data, e, f64::from_le_bytes),
        TypeId::I4 => chunks(data, e, |b| i32::from_le_bytes(b) as f64),
        _ => Values::decode(h, t, data).to_f64(),
    }
}

/// `data` (values of type `t`) decoded to `f64` as [`decode_f64`] does, into `out` (cleared
/// first): a buffer used again for every step.
pub(crate) fn decode_f64_into(h: &Header, t: TypeId, data: &[u8], out: &mut Vec<f64>) {
    fn each<const N: usize>(data: &[u8], e: Endian, out: &mut Vec<f64>, f: impl Fn([u8; N]) -> f64) {
        out.extend(data.chunks_exact(N).map(|c| {
            let mut b = [0u8; N];
            b.copy_from_slice(c);
            if e == Endian::Big {
                b.reverse();
            }
            f(b)
        }));
    }
    out.clear();
    let e = h.endian;
    match t {
        TypeId::R4 => each(data, e, out, |b| f32::from_le_bytes(b) as f64),
        TypeId::R8 => each(data, e, out, f64::from_le_bytes),
        TypeId::I4 => each(data, e, out, |b| i32::from_le_bytes(b) as f64),
        _ => out.extend(Values::decode(h, t, data).to_f64()),
    }
}

/// One value of type `t` (its `size` bytes) as `f64`, without allocating for the common types.
pub(crate) fn decode_one(h: &Header, t: TypeId, b: &[u8]) -> f64 {
    fn arr<const N: usize>(b: &[u8], e: Endian) -> [u8; N] {
        let mut a = [0u8; N];
        a.copy_from_slice(&b[..N]);
        if e == Endian::Big {
            a.reverse();
        }
        a
    }
    let e = h.endian;
    match t {
        TypeId::R4 => f32::from_le_bytes(arr(b, e)) as f64,
        TypeId::R8 => f64::from_le_bytes(arr(b, e)),
        TypeId::I4 => i32::from_le_bytes(arr(b, e)) as f64,
        TypeId::I8 => i64::from_le_bytes(arr(b, e)) as f64,
        _ => Values::decode(h, t, b).to_f64()[0],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_round_trips_bit_for_bit_in_both_orders() {
        let all = [
            Values::I1(vec![-128, 0, 127]),
            Values::I2(vec![-32768, 1, 32767]),
            Values::I4(vec![i32::MIN, -1, 1002285]),
            Values::I8(vec![i64::MIN, 42, i64::MAX]),
            Values::U1(vec![0, 255]),
            Values::U2(vec![0, 65535]),
            Values::U4(vec![0, u32::MAX]),
            Values::U8(vec![0, u64::MAX]),
            Values::R4(vec![
                0.0,
                -0.0,
                1e-38,
                f32::MIN_POSITIVE / 2.0,
                3.4148092,
                f32::INFINITY,
            ]),
            Values::R8(vec![0.0, 6.0802292864536867e-05, f64::MAX, -1e-310]),
            Values::Link(b"/glstat/metadata/title".to_vec()),
        ];
        for endian in [Endian::Little, Endian::Big] {
            let h = Header {
                endian,
                ..Header::default()
            };
            for v in &all {
                let mut bytes = Vec::new();
                v.encode(&h, &mut bytes);
                assert_eq!(bytes.len(), v.len() * v.type_id().size());
                let back = Values::decode(&h, v.type_id(), &bytes);
                let bits = |x: &Values| format!("{:?}", x.to_f64().iter().map(|f| f.to_bits()).collect::<Vec<_>>());
                assert_eq!(bits(&back), bits(v), "{endian:?}");
                assert_eq!(back.type_id(), v.type_id());
                assert_eq!(TypeId::from_code(v.type_id().code() as i64), Some(v.type_id()));
            }
        }
        assert_eq!(Values::U8(vec![u64::MAX]).to_i64(), None);
        assert_eq!(Values::from_text("01/07/2015").text().as_deref(), Some("01/07/2015"));
        assert_eq!(TypeId::from_code(12), None);
    }
}
