//! `nodout`: nodal displacements, velocities, accelerations and coordinates over time.
//!
//! A block per output step headed
//! ` n o d a l   p r i n t   o u t   f o r   t i m e  s t e p N  ( at time T )`; the time field's width
//! and style vary between writers (`%14.7E` in LSTC `l2a.c`, `%12.5E`, `0.1000E-02`), so the heading is
//! matched on the letter-spaced words (white space allowed between letters, required between
//! words: the regular expression in the tests, which the matcher is checked against) and the number
//! read by the Fortran number rules. Then a column header ` nodal point  x-disp ...` and rows of node id + 12 values
//! (x/y/z disp, vel, accl, coor). A block whose header names `x-rot` holds rotations: node id + 9 values
//! (rot, rot vel, rot acc), kept in [`Nodout::rotations`].

use super::text::{Tok, body, err, parse_number, read_text, tokens_into, whole};
use crate::error::InputError;
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, Clone, Default, PartialEq)]
pub struct NodeSeries {
    pub time: Vec<f64>,
    pub disp: [Vec<f64>; 3],
    pub vel: [Vec<f64>; 3],
    pub accl: [Vec<f64>; 3],
    pub coor: [Vec<f64>; 3],
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct NodeRotSeries {
    pub time: Vec<f64>,
    pub rot: [Vec<f64>; 3],
    pub rot_vel: [Vec<f64>; 3],
    pub rot_acc: [Vec<f64>; 3],
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct Nodout {
    pub title: String,
    /// Time step number and time of each block, in file order.
    pub steps: Vec<(u64, f64)>,
    pub nodes: BTreeMap<u64, NodeSeries>,
    pub rotations: BTreeMap<u64, NodeRotSeries>,
    /// Each block in file order: its heading's line, time, and the nodes of its translational rows.
    pub blocks: Vec<NodoutBlock>,
}

/// One ` n o d a l   p r i n t   o u t` block: what the completeness check walks.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NodoutBlock {
    pub line: usize,
    pub time: f64,
    /// Node ids of the translational rows, in file order (with repeats, if the file repeats them).
    pub nodes: Vec<u64>,
}

/// The heading's text parts, the time step number and the time, or `None` when `line` is not a
/// heading: the regular expression
/// `^\s*n\s*o\s*d\s*a\s*l\s+p\s*r\s*i\s*n\s*t\s+o\s*u\s*t\s+f\s*o\s*r\s+t\s*i\s*m\s*e\s+s\s*t\s*e\s*p\s*(\d+)\s*\(\s*at\s*time\s*(\S+?)\s*\)\s*$`
/// matched by hand (a regex engine took most of the time of reading a nodout).
fn heading_parts(line: &str) -> Option<(&str, &str)> {
    let mut rest = line.trim_start();
    for (w, word) in ["nodal", "print", "out", "for", "time", "step"].iter().enumerate() {
        if w > 0 {
            let after = rest.trim_start();
            if after.len() == rest.len() {
                return None; // words are separated by white space
            }
            rest = after;
        }
        for (k, letter) in word.chars().enumerate() {
            if k > 0 {
                rest = rest.trim_start();
            }
            rest = rest.strip_prefix(letter)?;
        }
    }
    rest = rest.trim_start();
    let digits = rest.find(|c: char| !c.is_ascii_digit()).unwrap_or(rest.len());
    let (step, after) = rest.split_at(digits);
    if step.is_empty() {
        return None;
    }
    rest = after.trim_start().strip_prefix('(')?.trim_start();
    rest = rest.strip_prefix("at")?.trim_start().strip_prefix("time")?.trim_start();
    let time = rest.trim_end().strip_suffix(')')?.trim_end();
    if time.is_empty() || time.contains(char::is_whitespace) {
        return None;
    }
    Some((step, time))
}

pub fn read(file: &Path) -> Result<Nodout, InputError> {
    parse(file, &read_text(file)?)
}

#[derive(Clone, Copy, PartialEq)]
enum Block {
    None,
    Heading,
    Trans,
    Rot,
}

/// Reads nodout text: headings set the block's step and time, column headers its kind
/// (translations or rotations), and each data row is appended to its node's series.
pub fn parse(file: &Path, text: &str) -> Result<Nodout, InputError> {
    let b = body(file, text, "nodout")?;
    let mut out = Nodout {
        title: b.title.to_string(),
        ..Default::default()
    };
    let mut state = Block::None;
    let mut time = 0.0;
    let mut t = Vec::new();
    for &(no, line) in &b.lines {
        if line.trim().is_empty() {
            continue;
        }
        if let Some(parts) = heading_parts(line) {
            let step = heading(file, text, no, parts)?;
            time = step.1;
            out.steps.push(step);
            out.blocks.push(NodoutBlock {
                line: no,
                time,
                nodes: Vec::new(),
            });
            state = Block::Heading;
            continue;
        }
        tokens_into(line, &mut t);
        if t[0].text().eq_ignore_ascii_case("nodal") {
            if state == Block::None {
                return Err(err(
                    file,
                    text,
                    no,
                    "column header before any ` n o d a l   p r i n t   o u t` heading",
                ));
            }
            state = if line.contains("x-rot") {
                Block::Rot
            } else {
                Block::Trans
            };
            continue;
        }
        let (id, vals) = data_row(file, text, no, line, &t, state)?;
        out.push(state, id, time, &vals);
    }
    Ok(out)
}

/// A block heading's time step number and time.
fn heading(file: &Path, text: &str, no: usize, (step, time): (&str, &str)) -> Result<(u64, f64), InputError> {
    let step: u64 = step
        .parse()
        .map_err(|_| err(file, text, no, "time step number out of range"))?;
    let time = parse_number(time).ok_or_else(|| {
        err(
            file,
            text,
            no,
            format!("expected a time after `at time`, found `{time}`"),
        )
    })?;
    Ok((step, time))
}

/// A data row of a block of kind `state`: node id and 12 (translations) or 9 (rotations) numbers.
fn data_row(
    file: &Path,
    text: &str,
    no: usize,
    line: &str,
    t: &[Tok],
    state: Block,
) -> Result<(u64, Vec<f64>), InputError> {
    let fail = |message: String| err(file, text, no, message);
    if line.as_bytes().windows(9).any(|w| w.eq_ignore_ascii_case(b"n o d a l")) {
        return Err(fail(
            "malformed heading: expected ` n o d a l   p r i n t   o u t   f o r   t i m e  s t e p N  ( at time T )`"
                .into(),
        ));
    }
    let want = match state {
        Block::Trans => 12,
        Block::Rot => 9,
        Block::None => return Err(fail("data before any ` n o d a l   p r i n t   o u t` heading".into())),
        Block::Heading => return Err(fail("expected the ` nodal point  x-disp ...` column header".into())),
    };
    let Some(id) = t[0].num().and_then(whole) else {
        return Err(fail(format!("expected a node id, found `{}`", t[0].text())));
    };
    let vals: Option<Vec<f64>> = t[1..].iter().map(Tok::num).collect();
    match vals {
        Some(v) if v.len() == want => Ok((id, v)),
        _ => Err(fail(format!(
            "expected node id and {want} numbers, found `{}`",
            line.trim()
        ))),
    }
}

impl Nodout {
    /// Appends a data row to its node's translation or rotation series.
    fn push(&mut self, state: Block, id: u64, time: f64, vals: &[f64]) {
        if state == Block::Trans {
            if let Some(b) = self.blocks.last_mut() {
                b.nodes.push(id);
            }
            let s = self.nodes.entry(id).or_default();
            s.time.push(time);
            for k in 0..3 {
                s.disp[k].push(vals[k]);
                s.vel[k].push(vals[3 + k]);
                s.accl[k].push(vals[6 + k]);
                s.coor[k].push(vals[9 + k]);
            }
        } else {
            let s = self.rotations.entry(id).or_default();
            s.time.push(time);
            for k in 0..3 {
                s.rot[k].push(vals[k]);
                s.rot_vel[k].push(vals[3 + k]);
                s.rot_acc[k].push(vals[6 + k]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::heading_parts;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use regex::Regex;

    /// The heading as the regular expression the readers used before reads it.
    fn by_regex(re: &Regex, line: &str) -> Option<(String, String)> {
        re.captures(line).map(|c| (c[1].to_string(), c[2].to_string()))
    }

    fn heading_regex() -> Regex {
        Regex::new(r"^\s*n\s*o\s*d\s*a\s*l\s+p\s*r\s*i\s*n\s*t\s+o\s*u\s*t\s+f\s*o\s*r\s+t\s*i\s*m\s*e\s+s\s*t\s*e\s*p\s*(\d+)\s*\(\s*at\s*time\s*(\S+?)\s*\)\s*$").unwrap()
    }

    /// A heading with random spacing, sometimes broken (a letter changed, a space or bracket
    /// dropped or doubled).
    fn draw(rng: &mut ChaCha8Rng) -> String {
        let spaces = |rng: &mut ChaCha8Rng, min: usize| " ".repeat(rng.random_range(min..min + 3));
        let mut line = spaces(rng, 0);
        for (w, word) in ["nodal", "print", "out", "for", "time", "step"].iter().enumerate() {
            if w > 0 {
                line += &spaces(rng, 1);
            }
            for (k, c) in word.chars().enumerate() {
                if k > 0 && rng.random_bool(0.5) {
                    line += &spaces(rng, 1);
                }
                line.push(c);
            }
        }
        let times = [
            "0.0000000E+00",
            "5.0000E-04",
            "0.1000E-02",
            "1.234-100",
            "***",
            "1.0e-3)",
        ];
        line += &format!(
            "{}{}{}({}at{}time{}{}{}){}",
            spaces(rng, 0),
            rng.random_range(0..100_000u32),
            spaces(rng, 0),
            spaces(rng, 0),
            spaces(rng, 0),
            spaces(rng, 0),
            times[rng.random_range(0..times.len())],
            spaces(rng, 0),
            spaces(rng, 0),
        );
        if rng.random_bool(0.4) {
            let mut chars: Vec<char> = line.chars().collect();
            let at = rng.random_range(0..chars.len());
            match rng.random_range(0..4) {
                0 => {
                    chars.remove(at);
                }
                1 => chars.insert(at, ' '),
                2 => chars.insert(at, ')'),
                _ => chars[at] = chars[at].to_ascii_uppercase(),
            }
            line = chars.into_iter().collect();
        }
        line
    }

    #[test]
    fn the_heading_matcher_agrees_with_the_regular_expression() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let re = heading_regex();
        let (mut matched, mut refused) = (0, 0);
        for _ in 0..20_000 {
            let line = draw(&mut rng);
            let hand = heading_parts(&line).map(|(a, b)| (a.to_string(), b.to_string()));
            assert_eq!(hand, by_regex(&re, &line), "{line:?}");
            if hand.is_some() { matched += 1 } else { refused += 1 }
        }
        // Both sides of the rule are exercised.
        assert!(
            matched > 5_000 && refused > 2_000,
            "{matched} matched, {refused} refused"
        );
        for line in ["nodal point  x-disp", " 9000005  0.0000E+00", "", " n o d a l"] {
            assert_eq!(heading_parts(line), None);
        }
    }
}
