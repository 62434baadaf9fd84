//! The record layer of a T01 file: Fortran-style sequential records, each a big-endian 32-bit
//! byte count, the bytes, and the same count again. Integers and reals inside are big-endian
//! 32-bit; text is ASCII padded with blanks.

use crate::Error;

/// One record: its payload and where it starts in the file (the offset of its leading count).
#[derive(Debug, Clone, Copy)]
pub struct Record<'a> {
    pub offset: usize,
    pub bytes: &'a [u8],
}

/// Walks the records of a byte buffer in order.
pub struct Records<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Records<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Records { bytes, at: 0 }
    }

    /// Offset of the next record (the end of the buffer when all are read).
    pub fn offset(&self) -> usize {
        self.at
    }

    pub fn at_end(&self) -> bool {
        self.at >= self.bytes.len()
    }

    /// The next record; `what` names it in errors.
    pub fn next_record(&mut self, what: &str) -> Result<Record<'a>, Error> {
        let offset = self.at;
        let count = self.marker(offset, what)?;
        let start = offset + 4;
        let end = start
            .checked_add(count)
            .filter(|e| e + 4 <= self.bytes.len())
            .ok_or_else(|| Error::Truncated {
                offset,
                what: what.to_string(),
                detail: format!(
                    "a record of {count} bytes does not fit in the {} bytes left",
                    self.bytes.len() - offset
                ),
            })?;
        let trailing = self.marker(end, what)?;
        if trailing != count {
            return Err(Error::Format {
                offset: end,
                what: what.to_string(),
                detail: format!("record length markers differ: {count} before, {trailing} after"),
            });
        }
        self.at = end + 4;
        Ok(Record {
            offset,
            bytes: &self.bytes[start..end],
        })
    }

    /// The next record, which must hold exactly `n` 32-bit words.
    pub fn words(&mut self, n: usize, what: &str) -> Result<Record<'a>, Error> {
        let r = self.next_record(what)?;
        if r.bytes.len() != 4 * n {
            return Err(Error::Format {
                offset: r.offset,
                what: what.to_string(),
                detail: format!("expected {} bytes ({n} values), found {}", 4 * n, r.bytes.len()),
            });
        }
        Ok(r)
    }

    fn marker(&self, offset: usize, what: &str) -> Result<usize, Error> {
        let Some(b) = self.bytes.get(offset..offset + 4) else {
            return Err(Error::Truncated {
                offset,
                what: what.to_string(),
                detail: "the file ends inside a record length marker".into(),
            });
        };
        let n = i32::from_be_bytes([b[0], b[1], b[2], b[3]]);
        usize::try_from(n).map_err(|_| Error::Format {
            offset,
            what: what.to_string(),
            detail: format!("negative record length {n}"),
        })
    }
}

impl Record<'_> {
    /// The `i`-th 32-bit word as a signed integer (the caller checked the length).
    pub fn int(&self, i: usize) -> i32 {
        let b = &self.bytes[4 * i..4 * i + 4];
        i32::from_be_bytes([b[0], b[1], b[2], b[3]])
    }

    /// The `i`-th word as a non-negative count.
    pub fn count(&self, i: usize, what: &str) -> Result<usize, Error> {
        let v = self.int(i);
        usize::try_from(v).map_err(|_| Error::Format {
            offset: self.offset + 4 + 4 * i,
            what: what.to_string(),
            detail: format!("negative count {v}"),
        })
    }

    /// All words as integers.
    pub fn ints(&self) -> Vec<i32> {
        (0..self.bytes.len() / 4).map(|i| self.int(i)).collect()
    }

    /// All words as reals.
    pub fn reals(&self) -> impl Iterator<Item = f32> + '_ {
        self.bytes
            .chunks_exact(4)
            .map(|b| f32::from_be_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// `len` bytes of text from byte `start`, blanks and NULs trimmed at the end.
    pub fn text(&self, start: usize, len: usize) -> String {
        let end = (start + len).min(self.bytes.len());
        let raw = self.bytes.get(start..end).unwrap_or(&[]);
        String::from_utf8_lossy(raw).trim_end_matches([' ', '\0']).to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(payload: &[u8]) -> Vec<u8> {
        let n = (payload.len() as i32).to_be_bytes();
        [&n[..], payload, &n[..]].concat()
    }

    #[test]
    fn reads_records_in_order_and_checks_markers() {
        let mut bytes = record(&7i32.to_be_bytes());
        bytes.extend(record(&1.5f32.to_be_bytes()));
        let mut r = Records::new(&bytes);
        assert_eq!(r.next_record("a").unwrap().int(0), 7);
        let second = r.words(1, "b").unwrap();
        assert_eq!(second.offset, 12);
        assert_eq!(second.reals().next(), Some(1.5));
        assert!(r.at_end());
        assert!(matches!(r.next_record("c"), Err(Error::Truncated { offset: 24, .. })));
    }

    #[test]
    fn mismatched_or_cut_records_are_errors_with_offsets() {
        let mut bytes = record(&[0; 8]);
        bytes[15] = 9; // trailing marker 9, leading 8
        assert!(matches!(
            Records::new(&bytes).next_record("x"),
            Err(Error::Format { offset: 12, .. })
        ));
        let cut = &record(&[0; 8])[..10];
        assert!(matches!(
            Records::new(cut).next_record("x"),
            Err(Error::Truncated { offset: 0, .. })
        ));
        assert!(matches!(
            Records::new(&record(&[0; 8])).words(3, "x"),
            Err(Error::Format { offset: 0, .. })
        ));
    }
}
