//! Property tests: every reader on random bytes, on every truncation of every format sample, and on
//! samples with a byte changed, returns Ok or Err and never panics; errors name the file.

use lab::extract::crush::{CsvOptions, ForceUnit, parse_test_csv};
use lab::extract::lsdyna::{bndout, glstat, nodout, rcforc, secforc, spcforc, termination};
use proptest::prelude::*;
use std::path::Path;

const SAMPLES: &[&str] = &[
    "rcforc_master_slave",
    "rcforc_surfa_surfb_moments",
    "glstat",
    "nodout",
    "bndout",
    "secforc",
    "spcforc",
    "d3hsp_normal",
    "messag_error",
    "stdout_missing",
    "test_machine_kN.csv",
    "test_machine_N.csv",
];

fn sample(name: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures/format-samples")
            .join(name),
    )
    .unwrap()
}

/// Run every reader; errors must name the file.
fn all_readers(bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    let f = Path::new("some/file");
    let check = |r: Result<(), lab::error::InputError>| {
        if let Err(e) = r {
            assert!(e.to_string().starts_with("some/file"), "{e}");
        }
    };
    check(rcforc::parse(f, &text).map(|_| ()));
    check(glstat::parse(f, &text).map(|_| ()));
    check(nodout::parse(f, &text).map(|_| ()));
    check(bndout::parse(f, &text).map(|_| ()));
    check(secforc::parse(f, &text).map(|_| ()));
    check(spcforc::parse(f, &text).map(|_| ()));
    let _ = termination::parse(&text);
    check(parse_test_csv(f, &text, CsvOptions::default()).map(|_| ()));
    check(
        parse_test_csv(
            f,
            &text,
            CsvOptions {
                force_unit: Some(ForceUnit::Newton),
            },
        )
        .map(|_| ()),
    );
}

#[test]
fn every_truncation_of_every_sample() {
    for name in SAMPLES {
        let b = sample(name);
        for cut in 0..=b.len() {
            all_readers(&b[..cut]);
        }
    }
}

#[test]
fn every_sample_parses_with_its_reader() {
    let f = Path::new("s");
    let text = |n: &str| String::from_utf8(sample(n)).unwrap();
    rcforc::parse(f, &text("rcforc_master_slave")).unwrap();
    glstat::parse(f, &text("glstat")).unwrap();
    nodout::parse(f, &text("nodout")).unwrap();
    bndout::parse(f, &text("bndout")).unwrap();
    secforc::parse(f, &text("secforc")).unwrap();
    spcforc::parse(f, &text("spcforc")).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        all_readers(&bytes);
    }

    #[test]
    fn random_ascii_lines(lines in proptest::collection::vec("[ -~]{0,40}", 0..20)) {
        let mut s = String::from(" title\n ls-dyna (version x) date y\n");
        s.push_str(&lines.join("\n"));
        all_readers(s.as_bytes());
    }

    #[test]
    fn sample_with_a_byte_changed(which in 0..SAMPLES.len(), pos in any::<prop::sample::Index>(), byte in any::<u8>()) {
        let mut b = sample(SAMPLES[which]);
        let i = pos.index(b.len());
        b[i] = byte;
        all_readers(&b);
    }

    #[test]
    fn sample_with_a_chunk_removed(which in 0..SAMPLES.len(), a in any::<prop::sample::Index>(), len in 0usize..40) {
        let b = sample(SAMPLES[which]);
        let i = a.index(b.len());
        let j = (i + len).min(b.len());
        let mut c = b[..i].to_vec();
        c.extend_from_slice(&b[j..]);
        all_readers(&c);
    }
}
