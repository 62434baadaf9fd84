//! The honeycomb template: rendered with a fixed context it matches the checked-in snapshot and
//! passes the lint; the lint catches what it should; the filters fail loudly.
//!
//! Refresh the snapshot after an intended template change with `UPDATE_SNAPSHOTS=1 cargo test`.

use lab::render::lsdyna::{self, lint};
use lab::render::mesh::{self, TubeSpec};
use tera::{Context, Tera};

const TEMPLATE: &str = include_str!("../templates/honeycomb/main.k.tera");
const SNAPSHOT: &str = "tests/snapshots/honeycomb_c3t8.k";

fn tera() -> Tera {
    let mut tera = Tera::new();
    lsdyna::register(&mut tera);
    tera.add_raw_template("main.k.tera", TEMPLATE).unwrap();
    tera
}

fn context() -> Context {
    let mut ctx = Context::new();
    ctx.insert("c", &3.0);
    ctx.insert("t", &0.08);
    ctx.insert("sigma_y", &185.0);
    ctx.insert("design_name", "C3T8");
    ctx.insert("ribbon_factor", &2);
    ctx
}

fn render(ctx: &Context) -> Result<String, tera::Error> {
    tera().render("main.k.tera", ctx)
}

fn coarse_mesh() -> String {
    mesh::include(&TubeSpec::paper(3.0, 3.0)).unwrap().0
}

#[test]
fn snapshot_matches_and_lints_clean() {
    let deck = render(&context()).unwrap();
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
        std::fs::write(SNAPSHOT, &deck).unwrap();
    }
    let expected = std::fs::read_to_string(SNAPSHOT).expect("snapshot missing: run with UPDATE_SNAPSHOTS=1");
    assert_eq!(deck, expected, "rendered deck differs from {SNAPSHOT}");
    let mesh = coarse_mesh();
    let problems = lint::lint(&deck, &|name| (name == "mesh.k").then(|| mesh.clone()));
    assert!(
        problems.is_empty(),
        "{}",
        problems.iter().map(|p| p.to_string()).collect::<Vec<_>>().join("\n")
    );
}

#[test]
fn defaults_and_the_crushsim_switch_render() {
    let mut ctx = context();
    ctx.insert("etan", &500.0);
    ctx.insert("crushsim_test", "hang");
    ctx.insert("crushsim_test_value", &30);
    let deck = render(&ctx).unwrap();
    assert!(deck.contains("R ETAN         500.0"), "{deck}");
    assert!(deck.contains("R TRIB          0.16"));
    assert!(deck.contains("*CRUSHSIM_TEST\nhang            30.0\n*END\n"), "{deck}");
    let plain = render(&context()).unwrap();
    assert!(!plain.contains("CRUSHSIM"));
    assert!(plain.ends_with("mesh.k\n*END\n"));
}

#[test]
fn a_value_that_does_not_fit_fails_the_render() {
    let mut ctx = context();
    ctx.insert("sigma_y", &137.2839102938401);
    let err = format!("{:?}", render(&ctx).unwrap_err());
    assert!(
        err.contains("137.2839102938401") && err.contains("10-character"),
        "{err}"
    );
}

fn problems(deck: &str) -> Vec<String> {
    lint::lint(deck, &|name| (name == "mesh.k").then(String::new))
        .into_iter()
        .map(|p| p.to_string())
        .collect()
}

#[test]
fn lint_catches_a_field_spilling_over() {
    let deck = render(&context()).unwrap().replace(
        "         1      &RHO     &EMOD       &PR     &SIGY",
        "         1      &RHO      &EMOD       &PR    &SIGY",
    );
    let p = problems(&deck);
    assert!(
        p.iter().any(|m| m.contains("&EMOD") || m.contains("not a real")),
        "{p:?}"
    );
    let deck = render(&context()).unwrap().replace(
        "         1         2    0.8333         5",
        "         1         2    0.8333  5.000001",
    );
    let p = problems(&deck);
    assert!(p.iter().any(|m| m.contains("not an integer")), "{p:?}");
}

#[test]
fn lint_catches_an_undefined_reference() {
    let deck = render(&context())
        .unwrap()
        .replace("     &TEND         0", "    &TENDX         0");
    let p = problems(&deck);
    assert!(p.iter().any(|m| m.contains("&TENDX is not defined")), "{p:?}");
}

#[test]
fn lint_catches_a_missing_include() {
    let p: Vec<String> = lint::lint(&render(&context()).unwrap(), &|_| None)
        .into_iter()
        .map(|p| p.to_string())
        .collect();
    assert!(p.iter().any(|m| m.contains("\"mesh.k\" does not exist")), "{p:?}");
}

#[test]
fn lint_catches_end_not_last() {
    let deck = render(&context()).unwrap() + "*NODE\n";
    let p = problems(&deck);
    assert!(p.iter().any(|m| m.contains("*END must be the last line")), "{p:?}");
}

#[test]
fn lint_catches_long_lines_and_blank_cards() {
    let deck = render(&context())
        .unwrap()
        .replace("*TITLE\n", &format!("*TITLE\n{}\n\n", "x".repeat(81)));
    let p = problems(&deck);
    assert!(p.iter().any(|m| m.contains("81 columns")), "{p:?}");
    assert!(p.iter().any(|m| m.contains("blank line")), "{p:?}");
}
