//! The three binout files LS-DYNA R7.1.2, R9.3.1 and R12.2.1 wrote (`fixtures/lsdyna-real/`):
//! read whole, with the figures lasso-python 2.0.4 reads from them (`lasso-python-reads.txt`
//! there; the full variable-by-variable comparison against lasso-python is lab's
//! `tests/binout_lasso.rs`).

use lsda::{Database, Endian, TypeId};
use std::path::PathBuf;

fn open(version: &str) -> Database {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("../fixtures/lsdyna-real/{version}/binout"));
    Database::open(&p).unwrap()
}

/// A variable's values gathered over the output-step directories, in their order.
fn over_steps(db: &Database, dir: &str, name: &str) -> Vec<f64> {
    db.subdirs(dir)
        .unwrap()
        .filter(|d| d.starts_with('d'))
        .flat_map(|d| db.variable(&format!("{dir}/{d}/{name}")).unwrap().to_f64())
        .collect()
}

#[test]
fn the_three_versions_read_whole_with_lasso_pythons_figures() {
    // (version, glstat last time, last cycle, cycle sum, rwforc normal force sum)
    let cases = [
        ("R7_1_2", 0.03478036820888519, 573.0, 25224.0, 197.3594512939453),
        ("R9_3_1", 0.03478037565946579, 573.0, 25224.0, 197.50226593017578),
        ("R12_2_1", 0.03475764021277428, 636.0, 28029.0, 173.0030379295349),
    ];
    for (v, last_time, last_cycle, cycle_sum, normal_sum) in cases {
        let db = open(v);
        assert!(db.notes().is_empty(), "{v}: {:?}", db.notes());
        let h = db.header(0).unwrap();
        assert_eq!(
            (h.length_size, h.offset_size, h.command_size, h.type_size, h.endian),
            (8, 8, 1, 1, Endian::Little)
        );
        assert_eq!(
            db.subdirs("/").unwrap().collect::<Vec<_>>(),
            ["glstat", "matsum", "rcforc", "rwforc"]
        );
        let time = over_steps(&db, "/glstat", "time");
        assert_eq!(time.len(), 88, "{v}");
        assert_eq!(time[87], last_time, "{v}");
        let cycle = over_steps(&db, "/glstat", "cycle");
        assert_eq!((cycle[87], cycle.iter().sum::<f64>()), (last_cycle, cycle_sum), "{v}");
        let normal = over_steps(&db, "/rwforc/forces", "normal_force");
        // lasso sums the same float32 values in float64, in the same order.
        assert_eq!(normal.iter().sum::<f64>(), normal_sum, "{v}");
        let peak = normal.iter().copied().fold(0.0, f64::max);
        assert!((130.0..170.0).contains(&peak), "{v}: peak {peak}");
        eprintln!("{v}: rwforc normal force peak {peak}");
        assert_eq!(db.variable("/glstat/d000001/time").unwrap().type_id(), TypeId::R4);
        let title = db.variable("/glstat/metadata/title").unwrap().values().text().unwrap();
        assert_eq!(title.trim_end(), "SPH Unit Test");
        let rc_ids = db.variable("/rcforc/metadata/ids").unwrap();
        assert!(rc_ids.is_empty());
    }
}
