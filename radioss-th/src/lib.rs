//! `radioss-th`: a reader of OpenRadioss time-history files (`<root>T01`).
//!
//! The engine of OpenRadioss writes what it was asked to record over time into one binary file,
//! `<root>T01` (for a deck `main.k`, `mainT01`), at the interval of `/TFILE` (for an LS-DYNA deck,
//! the smallest DT of its `*DATABASE_` cards). It holds the global energies (the LS-DYNA glstat
//! equivalent), each part's energies, momenta and mass, every contact interface's forces (the
//! rcforc equivalent; for a converted LS-DYNA deck interface 1 is its first `*CONTACT`) and the
//! displacements, velocities and accelerations of the history nodes (`*DATABASE_HISTORY_NODE`, the
//! nodout equivalent).
//!
//! # The format
//!
//! A sequence of Fortran-style records: a big-endian 32-bit byte count, the bytes, the count again.
//! Numbers inside are big-endian 32-bit integers and IEEE reals (single precision); titles are
//! blank-padded ASCII, 40 characters unless said otherwise.
//!
//! ```text
//! header   [version, title(80)] [banner(80)] [parts, materials, properties, subsets, groups, globals]
//!          [global variable ids]
//!          per part:     [id, title, _, _, _, nvar] [nvar variable ids]
//!          per material: [id, title]       per property: [id, title]
//!          per subset:   [id, parent, nsubsets, nparts, nvar, title] [subsets] [parts] [variable ids]
//!          per group:    [id, kind, _, nelements, nvar, title] per element: [id, title] [variable ids]
//! per step [time] [global values] [part values, parts in order] [subset values]
//!          per group: [element-major values: element 1's variables, element 2's, ...]
//! ```
//!
//! A record whose count would be zero (no ids, no values) is not written. Interface variables
//! (`FNX` ... `FTZ`) are impulses, forces integrated from time 0; [`TimeHistory::interface_force`]
//! differentiates them as OpenRadioss's converter `th_to_csv` does (central differences inside,
//! one-sided at both ends), so its numbers equal the converter's CSV. Variable names are tables
//! by id ([`names`]), checked against `th_to_csv`'s CSV header in `tests/th_to_csv.rs`.
//!
//! # Use
//!
//! ```no_run
//! let th = radioss_th::read(std::path::Path::new("run/mainT01"))?;
//! let internal = th.global("INTERNAL ENERGY").expect("recorded");
//! let stroke = th.node(9000005, "DZ").expect("a history node");
//! let force = th.interface_force(1, "FNZ").expect("interface 1");
//! println!("{} steps, last internal energy {}", th.times.len(), internal[internal.len() - 1]);
//! # let _ = (stroke, force);
//! # Ok::<(), radioss_th::Error>(())
//! ```
//!
//! Errors say where: the byte offset of the record, what it was meant to hold, and what was wrong;
//! a file cut inside a time step is [`Error::Truncated`] (the steps before it are lost with it: an
//! incomplete history is not a result).

pub mod header;
pub mod names;
pub mod record;

use std::path::Path;

pub use header::{Group, Header, Named, Part, Subset};

/// Why a T01 file could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    #[error("cannot read {path}: {message}")]
    Io { path: String, message: String },
    #[error("at byte {offset} ({what}): the file is cut short: {detail}")]
    Truncated {
        offset: usize,
        what: String,
        detail: String,
    },
    #[error("at byte {offset} ({what}): {detail}")]
    Format {
        offset: usize,
        what: String,
        detail: String,
    },
}

/// Where a column of values comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    Global,
    Part {
        id: i32,
    },
    Subset {
        id: i32,
    },
    /// An element (interface, node, ...) of a group of kind `kind`.
    Group {
        group: i32,
        kind: i32,
        element: i32,
    },
}

/// One recorded variable: where it comes from, its id and name.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    pub source: Source,
    pub variable: i32,
    pub name: String,
}

/// A whole time history: the header, the output times and every column's values per step.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeHistory {
    pub header: Header,
    pub times: Vec<f64>,
    /// In file order: globals, parts, subsets, then each group's elements.
    pub columns: Vec<Column>,
    /// Step-major: `values[step * columns.len() + column]`, as stored (single precision).
    pub values: Vec<f32>,
}

/// Reads a T01 file.
pub fn read(path: &Path) -> Result<TimeHistory, Error> {
    let bytes = std::fs::read(path).map_err(|e| Error::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    parse(&bytes)
}

/// Parses the bytes of a T01 file.
pub fn parse(bytes: &[u8]) -> Result<TimeHistory, Error> {
    let mut records = record::Records::new(bytes);
    let header = Header::read(&mut records)?;
    let columns = columns(&header);
    let mut th = TimeHistory {
        header,
        times: Vec::new(),
        columns,
        values: Vec::new(),
    };
    while !records.at_end() {
        th.read_step(&mut records)?;
    }
    Ok(th)
}

fn columns(h: &Header) -> Vec<Column> {
    let mut out: Vec<Column> = h
        .globals
        .iter()
        .map(|&v| Column {
            source: Source::Global,
            variable: v,
            name: names::global(v),
        })
        .collect();
    for p in &h.parts {
        out.extend(p.variables.iter().map(|&v| Column {
            source: Source::Part { id: p.id },
            variable: v,
            name: names::part(v),
        }));
    }
    for s in &h.subsets {
        out.extend(s.variables.iter().map(|&v| Column {
            source: Source::Subset { id: s.id },
            variable: v,
            name: names::part(v),
        }));
    }
    for g in &h.groups {
        for e in &g.elements {
            out.extend(g.variables.iter().map(|&v| Column {
                source: Source::Group {
                    group: g.id,
                    kind: g.kind,
                    element: e.id,
                },
                variable: v,
                name: names::group_variable(g.kind, v),
            }));
        }
    }
    out
}

impl TimeHistory {
    /// One time step: its time record and one record per block of values.
    fn read_step(&mut self, r: &mut record::Records) -> Result<(), Error> {
        let step = self.times.len() + 1;
        let time = r.words(1, &format!("time of step {step}"))?;
        let mut blocks = vec![
            (self.header.globals.len(), "global values".to_string()),
            (self.header.part_values(), "part values".to_string()),
            (self.header.subset_values(), "subset values".to_string()),
        ];
        blocks.extend(self.header.groups.iter().map(|g| {
            (
                g.elements.len() * g.variables.len(),
                format!("values of group {} ({})", g.id, g.title),
            )
        }));
        let start = self.values.len();
        for (n, what) in blocks.into_iter().filter(|(n, _)| *n > 0) {
            match r.words(n, &format!("{what}, step {step}")) {
                Ok(rec) => self.values.extend(rec.reals()),
                Err(e) => {
                    self.values.truncate(start);
                    return Err(e);
                }
            }
        }
        self.times.push(f64::from(time.reals().next().unwrap_or(f32::NAN)));
        Ok(())
    }

    /// The values of column `c` over time.
    pub fn series(&self, c: usize) -> Vec<f64> {
        let n = self.columns.len();
        (0..self.times.len())
            .map(|s| f64::from(self.values[s * n + c]))
            .collect()
    }

    fn find(&self, pred: impl Fn(&Column) -> bool) -> Option<Vec<f64>> {
        self.columns.iter().position(pred).map(|c| self.series(c))
    }

    /// A global variable by name (`"INTERNAL ENERGY"`, `"KINETIC ENERGY"`, `"EXTERNAL WORK"`, ...).
    pub fn global(&self, name: &str) -> Option<Vec<f64>> {
        self.find(|c| c.source == Source::Global && c.name == name)
    }

    /// A part's variable by name (`"IE"`, `"KE"`, `"MASS"`, ...).
    pub fn part(&self, id: i32, name: &str) -> Option<Vec<f64>> {
        self.find(|c| c.source == Source::Part { id } && c.name == name)
    }

    /// A history node's variable by name (`"DX"` ... `"ARZ"`).
    pub fn node(&self, id: i32, name: &str) -> Option<Vec<f64>> {
        self.find(|c| {
            matches!(c.source, Source::Group { kind: names::KIND_NODE, element, .. } if element == id) && c.name == name
        })
    }

    /// An interface's impulse component by name (`"FNX"` ... `"FTZ"`), as stored.
    pub fn interface_impulse(&self, id: i32, name: &str) -> Option<Vec<f64>> {
        self.find(|c| {
            matches!(c.source, Source::Group { kind: names::KIND_INTERFACE, element, .. } if element == id)
                && c.name == name
        })
    }

    /// An interface's force component (`"FNZ"`, ...): its impulse differentiated in time
    /// ([`force_from_impulse`]).
    pub fn interface_force(&self, id: i32, name: &str) -> Option<Vec<f64>> {
        self.interface_impulse(id, name)
            .map(|i| force_from_impulse(&self.times, &i))
    }

    /// The ids of the interfaces recorded, in file order.
    pub fn interfaces(&self) -> Vec<i32> {
        self.header
            .groups
            .iter()
            .filter(|g| g.kind == names::KIND_INTERFACE)
            .flat_map(|g| g.elements.iter().map(|e| e.id))
            .collect()
    }
}

/// Forces from a cumulative impulse, as `th_to_csv` computes them: central differences
/// `(I[k+1] − I[k−1]) / (t[k+1] − t[k−1])` inside, a forward difference at the first step and a
/// backward one at the last. Fewer than two steps give zeros. Where two times coincide the
/// difference is not finite; the caller's checks of the times catch that.
pub fn force_from_impulse(times: &[f64], impulse: &[f64]) -> Vec<f64> {
    let n = times.len().min(impulse.len());
    if n < 2 {
        return vec![0.0; n];
    }
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            (impulse[b] - impulse[a]) / (times[b] - times[a])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small T01 as the engine writes one: 2 globals, one part with 2 variables, the model's
    /// subset, an interface group (1 interface, FNZ only) and a node group (1 node, DZ only).
    fn file(steps: &[(f32, [f32; 6])]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut rec = |payload: Vec<u8>| {
            let n = (payload.len() as i32).to_be_bytes();
            out.extend(n);
            out.extend(&payload);
            out.extend(n);
        };
        let ints = |v: &[i32]| v.iter().flat_map(|i| i.to_be_bytes()).collect::<Vec<u8>>();
        let title = |t: &str, w: usize| format!("{t:<w$}").into_bytes();
        rec([ints(&[3040]), title("run", 80)].concat());
        rec(title("banner", 80));
        rec(ints(&[1, 0, 0, 1, 2, 2]));
        rec(ints(&[1, 2]));
        rec([ints(&[7]), title("tube", 40), ints(&[0, 1, 1, 2])].concat());
        rec(ints(&[1, 2]));
        rec([ints(&[0, 0, 0, 1, 0]), title("GLOBAL MODEL", 40)].concat());
        rec(ints(&[7]));
        rec([ints(&[3, 101, 0, 1, 1]), title("TH-INTER", 40)].concat());
        rec([ints(&[1]), title("NODES_TO_SURFACE", 40)].concat());
        rec(ints(&[3]));
        rec([ints(&[2, 0, 0, 1, 1]), title("NODES", 40)].concat());
        rec([ints(&[9000005]), title("", 40)].concat());
        rec(ints(&[3]));
        for (t, v) in steps {
            let reals = |v: &[f32]| v.iter().flat_map(|x| x.to_be_bytes()).collect::<Vec<u8>>();
            rec(reals(&[*t]));
            rec(reals(&v[0..2]));
            rec(reals(&v[2..4]));
            rec(reals(&v[4..5]));
            rec(reals(&v[5..6]));
        }
        out
    }

    #[test]
    fn reads_a_small_file_by_name() {
        let bytes = file(&[
            (0.0, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            (1e-3, [5.0, 0.5, 4.0, 0.25, 2e-3, -0.01]),
        ]);
        let th = parse(&bytes).unwrap();
        assert_eq!(th.header.version, 3040);
        assert_eq!(th.times, vec![0.0, f64::from(1e-3f32)]);
        assert_eq!(th.global("KINETIC ENERGY").unwrap(), vec![0.0, 0.5]);
        assert_eq!(th.part(7, "KE").unwrap(), vec![0.0, 0.25]);
        assert_eq!(th.node(9000005, "DZ").unwrap(), vec![0.0, f64::from(-0.01f32)]);
        let f = th.interface_force(1, "FNZ").unwrap();
        assert!((f[1] - 2.0).abs() < 1e-6, "{f:?}");
        assert_eq!(th.interfaces(), vec![1]);
        assert!(th.node(1, "DZ").is_none() && th.global("NO SUCH").is_none());
    }

    #[test]
    fn a_file_cut_inside_a_step_or_with_a_wrong_record_is_an_error_with_its_offset() {
        let bytes = file(&[(0.0, [0.0; 6]), (1e-3, [1.0; 6])]);
        let whole = parse(&bytes).unwrap();
        assert_eq!(whole.times.len(), 2);
        for cut in [bytes.len() - 1, bytes.len() - 12, bytes.len() - 30] {
            match parse(&bytes[..cut]) {
                Err(Error::Truncated { offset, what, .. }) => {
                    assert!(offset <= cut && what.contains("step 2"), "{offset} {what}")
                }
                other => panic!("cut at {cut}: {other:?}"),
            }
        }
        // A global record of 3 values where the header says 2.
        let mut bad = bytes.clone();
        let at = bad.len() - 4 * 5 - 8 * 4 - 4 * 2 - 8; // the last step's global record
        bad.splice(at..at + 4, 12i32.to_be_bytes());
        assert!(matches!(
            parse(&bad),
            Err(Error::Truncated { .. } | Error::Format { .. })
        ));
    }

    #[test]
    fn force_from_impulse_is_central_inside_and_one_sided_at_the_ends() {
        let t = [0.0, 1.0, 2.0, 4.0];
        let i = [0.0, 2.0, 6.0, 10.0];
        assert_eq!(force_from_impulse(&t, &i), vec![2.0, 3.0, 8.0 / 3.0, 2.0]);
        assert_eq!(force_from_impulse(&[0.0], &[1.0]), vec![0.0]);
    }
}
