//! Damaged files: cut at every offset, every byte flipped. Never a panic; a cut file reads up to
//! its last whole record with a note naming the offset; anything else is an error naming the
//! file and the offset, or (a flipped value byte) a file that still reads.

use lsda::{Database, Header, Values, Writer};

/// A small binout-like file: three output steps, a symbol table after each.
fn file() -> Vec<u8> {
    let mut w = Writer::new(Header::default());
    w.cd("/rcforc/metadata");
    w.write("title", &Values::from_text("crush")).unwrap();
    w.write("ids", &Values::I4(vec![1, 1])).unwrap();
    w.flush().unwrap();
    for k in 1..=3 {
        w.cd(&format!("/rcforc/d{k:06}"));
        w.write("time", &Values::R4(vec![k as f32 * 0.5])).unwrap();
        w.write("z_force", &Values::R4(vec![1.0, -1.0])).unwrap();
        w.flush().unwrap();
    }
    w.finish().unwrap().remove(0)
}

fn open(bytes: &[u8]) -> Result<Database, lsda::Error> {
    Database::from_bytes(vec![("binout".into(), bytes.to_vec())])
}

#[test]
fn a_cut_file_reads_up_to_its_last_whole_record_and_says_where() {
    let whole = file();
    let full = open(&whole).unwrap();
    assert!(full.notes().is_empty());
    let steps = |db: &Database| db.subdirs("/rcforc").map_or(0, |d| d.count());
    for cut in 0..whole.len() {
        match open(&whole[..cut]) {
            Ok(db) => {
                // Whatever it read is what the whole file holds.
                for dir in db.dirs() {
                    for (name, v) in db.variables(dir).unwrap() {
                        let w = full.variable_in(dir, name).unwrap();
                        assert_eq!(v.values(), w.values(), "cut {cut}: {dir}/{name}");
                    }
                }
                assert!(steps(&db) <= steps(&full));
                if cut > 8 {
                    let note = db.notes().first().unwrap_or_else(|| panic!("cut {cut}: no note"));
                    assert!(note.offset as usize <= cut, "{note}");
                    assert!(note.to_string().starts_with("binout: offset "), "{note}");
                }
            }
            Err(e) => {
                assert!(cut < 8, "cut {cut}: {e}");
                assert!(e.to_string().contains("offset 0"), "{e}");
            }
        }
    }
}

#[test]
fn every_flipped_byte_is_an_error_with_its_offset_or_still_reads() {
    let whole = file();
    let (mut errors, mut read) = (0, 0);
    for at in 0..whole.len() {
        for mask in [0x01u8, 0x80, 0xff] {
            let mut bytes = whole.clone();
            bytes[at] ^= mask;
            match open(&bytes) {
                Ok(_) => read += 1,
                Err(e) => {
                    errors += 1;
                    let text = e.to_string();
                    assert!(text.starts_with("binout: offset "), "{text}");
                }
            }
        }
    }
    // Most bytes are structure (lengths, commands, names, offsets), caught; value bytes are not.
    assert!(errors > read, "{errors} errors, {read} read");
}
