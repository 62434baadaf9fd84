//! The 8-byte file header: the sizes of lengths, offsets, commands and type codes, and the byte
//! order of every integer and real in the file.

/// Byte order of the file's numbers, as its header declares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Endian {
    Little,
    Big,
}

impl Endian {
    /// The byte order of this machine (what LSTC's writers put in the header).
    pub fn native() -> Endian {
        if cfg!(target_endian = "big") {
            Endian::Big
        } else {
            Endian::Little
        }
    }
}

/// An LSDA file header.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Header {
    /// Where the first record starts (8, or more when a writer padded the header).
    pub header_len: u8,
    /// Bytes of a record length (1, 2, 4 or 8).
    pub length_size: u8,
    /// Bytes of a file offset (1, 2, 4 or 8): 4 limits a file to 2 GiB.
    pub offset_size: u8,
    /// Bytes of a record's command code (1, 2, 4 or 8).
    pub command_size: u8,
    /// Bytes of a variable's type code (1, 2, 4 or 8).
    pub type_size: u8,
    pub endian: Endian,
}

impl Default for Header {
    /// What LS-DYNA and LSTC's `lsda` write: 8-byte lengths and offsets, 1-byte commands and
    /// type codes, this machine's byte order.
    fn default() -> Self {
        Header {
            header_len: 8,
            length_size: 8,
            offset_size: 8,
            command_size: 1,
            type_size: 1,
            endian: Endian::native(),
        }
    }
}

fn valid_size(s: u8) -> bool {
    matches!(s, 1 | 2 | 4 | 8)
}

impl Header {
    /// Reads the header at the start of `bytes`; the error says what is wrong (at offset 0).
    pub fn parse(bytes: &[u8]) -> Result<Header, String> {
        let Some(b) = bytes.get(..8) else {
            return Err(format!("{} bytes: too short for the 8-byte LSDA header", bytes.len()));
        };
        let endian = match b[5] {
            0 => Endian::Big,
            1 => Endian::Little,
            other => return Err(format!("header byte 5 (byte order) is {other}, expected 0 or 1")),
        };
        let h = Header {
            header_len: b[0],
            length_size: b[1],
            offset_size: b[2],
            command_size: b[3],
            type_size: b[4],
            endian,
        };
        if h.header_len < 8 {
            return Err(format!("header length {} is below 8", h.header_len));
        }
        let sizes = [
            ("length", h.length_size),
            ("offset", h.offset_size),
            ("command", h.command_size),
            ("type code", h.type_size),
        ];
        for (what, size) in sizes {
            if !valid_size(size) {
                return Err(format!(
                    "header: the {what} size is {size} bytes, expected 1, 2, 4 or 8: not an LSDA file"
                ));
            }
        }
        Ok(h)
    }

    /// The header's 8 bytes (bytes 6 and 7 are zero).
    pub fn encode(&self) -> [u8; 8] {
        let order = match self.endian {
            Endian::Big => 0,
            Endian::Little => 1,
        };
        [
            self.header_len,
            self.length_size,
            self.offset_size,
            self.command_size,
            self.type_size,
            order,
            0,
            0,
        ]
    }

    /// The signed integer of `size` bytes at `at`, or `None` past the end.
    #[inline(always)]
    pub(crate) fn int(&self, bytes: &[u8], at: usize, size: u8) -> Option<i64> {
        let raw = bytes.get(at..at.checked_add(size as usize)?)?;
        // The sizes LS-DYNA writes, read directly (most of a file's records are read here).
        match (size, self.endian) {
            (1, _) => return Some(raw[0] as i8 as i64),
            (8, Endian::Little) => return Some(i64::from_le_bytes(raw.try_into().ok()?)),
            (4, Endian::Little) => return Some(i32::from_le_bytes(raw.try_into().ok()?) as i64),
            (8, Endian::Big) => return Some(i64::from_be_bytes(raw.try_into().ok()?)),
            (4, Endian::Big) => return Some(i32::from_be_bytes(raw.try_into().ok()?) as i64),
            _ => {}
        }
        let mut buf = [0u8; 8];
        match self.endian {
            Endian::Little => {
                buf[..raw.len()].copy_from_slice(raw);
                let fill = if raw[raw.len() - 1] & 0x80 != 0 { 0xff } else { 0 };
                buf[raw.len()..].fill(fill);
                Some(i64::from_le_bytes(buf))
            }
            Endian::Big => {
                buf[8 - raw.len()..].copy_from_slice(raw);
                let fill = if raw[0] & 0x80 != 0 { 0xff } else { 0 };
                buf[..8 - raw.len()].fill(fill);
                Some(i64::from_be_bytes(buf))
            }
        }
    }

    /// Appends `v` as a signed integer of `size` bytes; `None` when it does not fit.
    pub(crate) fn put_int(&self, out: &mut Vec<u8>, v: i64, size: u8) -> Option<()> {
        let bits = 8 * size as u32;
        if bits < 64 && (v < -(1i64 << (bits - 1)) || v >= 1i64 << (bits - 1)) {
            return None;
        }
        match self.endian {
            Endian::Little => out.extend_from_slice(&v.to_le_bytes()[..size as usize]),
            Endian::Big => out.extend_from_slice(&v.to_be_bytes()[8 - size as usize..]),
        }
        Some(())
    }

    /// Overwrites the integer of `size` bytes at `at` (a length or offset patched in place).
    pub(crate) fn patch_int(&self, out: &mut [u8], at: usize, v: i64, size: u8) -> Option<()> {
        let mut buf = Vec::with_capacity(8);
        self.put_int(&mut buf, v, size)?;
        out.get_mut(at..at + size as usize)?.copy_from_slice(&buf);
        Some(())
    }

    /// Bytes of a record's length and command.
    pub(crate) fn record_head(&self) -> usize {
        self.length_size as usize + self.command_size as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integers_round_trip_in_both_orders_and_every_size() {
        for endian in [Endian::Little, Endian::Big] {
            let h = Header {
                endian,
                ..Header::default()
            };
            for size in [1u8, 2, 4, 8] {
                let bits = 8 * size as u32;
                let lo = if bits == 64 { i64::MIN } else { -(1i64 << (bits - 1)) };
                let hi = if bits == 64 { i64::MAX } else { (1i64 << (bits - 1)) - 1 };
                for v in [0, 1, -1, 17, lo, hi] {
                    let mut out = vec![9u8];
                    h.put_int(&mut out, v, size).unwrap();
                    assert_eq!(out.len(), 1 + size as usize);
                    assert_eq!(h.int(&out, 1, size), Some(v), "{endian:?} {size} {v}");
                }
                if bits < 64 {
                    assert_eq!(h.put_int(&mut Vec::new(), hi + 1, size), None);
                }
            }
        }
    }

    #[test]
    fn bad_headers_say_why() {
        assert!(Header::parse(&[8, 8, 8]).unwrap_err().contains("too short"));
        assert!(
            Header::parse(&[8, 8, 8, 1, 1, 2, 0, 0])
                .unwrap_err()
                .contains("byte order")
        );
        assert!(
            Header::parse(&[8, 3, 8, 1, 1, 1, 0, 0])
                .unwrap_err()
                .contains("length size")
        );
        assert!(
            Header::parse(&[7, 8, 8, 1, 1, 1, 0, 0])
                .unwrap_err()
                .contains("below 8")
        );
        let h = Header::parse(&[8, 8, 4, 1, 1, 0, 0, 0]).unwrap();
        assert_eq!((h.offset_size, h.endian), (4, Endian::Big));
        assert_eq!(Header::parse(&h.encode()).unwrap(), h);
    }
}
