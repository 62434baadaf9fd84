//! The writer's files read back equal by the reader: every type, both byte orders, 4- and
//! 8-byte offsets and lengths, several symbol tables, continuation files.

use lsda::{Database, Endian, Header, TypeId, Values, Writer};

fn sample() -> Vec<(&'static str, &'static str, Values)> {
    vec![
        ("/glstat/metadata", "title", Values::from_text("SPH Unit Test")),
        ("/glstat/metadata", "ids", Values::I4(vec![1, 101])),
        ("/glstat/d000001", "time", Values::R4(vec![0.0])),
        ("/glstat/d000001", "cycle", Values::I8(vec![1])),
        ("/glstat/d000001", "kinetic_energy", Values::R8(vec![3.414809226989746])),
        ("/glstat/d000002", "time", Values::R4(vec![3.478e-2])),
        ("/x/y/z", "i1", Values::I1(vec![-1, 2])),
        ("/x/y/z", "i2", Values::I2(vec![-300, 2])),
        ("/x/y", "u1", Values::U1(vec![255])),
        ("/x/y", "u2", Values::U2(vec![65535])),
        ("/x", "u4", Values::U4(vec![u32::MAX])),
        ("/x", "u8", Values::U8(vec![u64::MAX, 0])),
        ("/x", "empty", Values::R4(vec![])),
        ("/", "link", Values::Link(b"/glstat/metadata/title".to_vec())),
    ]
}

fn write(h: Header, flush_every: usize, split_at: Option<usize>) -> Vec<Vec<u8>> {
    let mut w = Writer::new(h);
    for (k, (dir, name, v)) in sample().iter().enumerate() {
        if Some(k) == split_at {
            w.next_file().unwrap();
        }
        w.cd(dir);
        w.write(name, v).unwrap();
        if (k + 1) % flush_every == 0 {
            w.flush().unwrap();
        }
    }
    w.finish().unwrap()
}

fn check(db: &Database) {
    for (dir, name, v) in sample() {
        let got = db
            .variable(&format!("{dir}/{name}"))
            .unwrap_or_else(|| panic!("{dir}/{name}"));
        assert_eq!(got.type_id(), v.type_id());
        assert_eq!(got.values(), v, "{dir}/{name}");
    }
    assert!(db.notes().is_empty(), "{:?}", db.notes());
    assert_eq!(
        db.subdirs("/glstat").unwrap().collect::<Vec<_>>(),
        ["d000001", "d000002", "metadata"]
    );
    assert!(db.is_dir("x/y/z"));
    assert_eq!(db.variable("/x/u8").unwrap().type_id(), TypeId::U8);
}

#[test]
fn every_layout_round_trips() {
    for endian in [Endian::Little, Endian::Big] {
        for (length_size, offset_size) in [(8, 8), (4, 4), (8, 4), (4, 8)] {
            for flush_every in [1, 3, 100] {
                let h = Header {
                    endian,
                    length_size,
                    offset_size,
                    ..Header::default()
                };
                let files = write(h, flush_every, None);
                assert_eq!(files.len(), 1);
                let db = Database::from_bytes(vec![("binout".into(), files[0].clone())]).unwrap();
                assert_eq!(db.header(0), Some(h));
                check(&db);
            }
        }
    }
}

#[test]
fn continuation_files_are_found_and_read_as_one() {
    let dir = tempfile::tempdir().unwrap();
    let mut w = Writer::new(Header::default());
    for (k, (d, name, v)) in sample().iter().enumerate() {
        if k == 5 || k == 9 {
            w.next_file().unwrap();
        }
        w.cd(d);
        w.write(name, v).unwrap();
    }
    let written = w.save(&dir.path().join("binout")).unwrap();
    let names: Vec<String> = written
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into())
        .collect();
    assert_eq!(names, ["binout", "binout%001", "binout%002"]);
    check(&Database::open(dir.path().join("binout")).unwrap());
    assert_eq!(lsda::set::find(dir.path(), "binout").unwrap(), written);
    // A missing continuation file is named.
    std::fs::remove_file(&written[1]).unwrap();
    let e = Database::open(dir.path().join("binout")).err().unwrap().to_string();
    assert!(e.contains("binout%001 is not there") && e.contains("binout%002"), "{e}");
}

#[test]
fn an_mpp_family_is_read_whole_or_named_where_it_has_a_gap() {
    let dir = tempfile::tempdir().unwrap();
    for (k, top) in ["glstat", "rcforc", "nodout"].iter().enumerate() {
        let mut w = Writer::new(Header::default());
        w.cd(&format!("/{top}/d000001"));
        w.write("time", &Values::R4(vec![k as f32])).unwrap();
        w.save(&dir.path().join(format!("binout{k:04}"))).unwrap();
    }
    let files = lsda::set::find(dir.path(), "binout").unwrap();
    assert_eq!(files.len(), 3);
    let db = Database::open_files(&files).unwrap();
    assert_eq!(db.variable("/nodout/d000001/time").unwrap().to_f64(), [2.0]);
    assert_eq!(
        db.subdirs("/").unwrap().collect::<Vec<_>>(),
        ["glstat", "nodout", "rcforc"]
    );
    std::fs::remove_file(dir.path().join("binout0001")).unwrap();
    let e = lsda::set::find(dir.path(), "binout").unwrap_err().to_string();
    assert!(e.contains("binout0001 is not there"), "{e}");
    assert!(lsda::set::find(&dir.path().join("nothing-here"), "binout").is_err());
}

#[test]
fn a_later_variable_of_the_same_path_replaces_the_earlier() {
    let mut w = Writer::new(Header::default());
    w.cd("/a");
    w.write("v", &Values::I4(vec![1])).unwrap();
    w.flush().unwrap();
    w.write("v", &Values::I4(vec![2, 3])).unwrap();
    let files = w.finish().unwrap();
    let db = Database::from_bytes(vec![("f".into(), files[0].clone())]).unwrap();
    assert_eq!(db.variable("/a/v").unwrap().values(), Values::I4(vec![2, 3]));
}

#[test]
fn names_that_do_not_fit_are_refused() {
    let mut w = Writer::new(Header::default());
    assert!(w.write("", &Values::I4(vec![1])).is_err());
    assert!(w.write("a/b", &Values::I4(vec![1])).is_err());
    assert!(w.write(&"n".repeat(256), &Values::I4(vec![1])).is_err());
    let mut small = Writer::new(Header {
        length_size: 1,
        ..Header::default()
    });
    assert!(small.write("big", &Values::R8(vec![0.0; 100])).is_err());
}
