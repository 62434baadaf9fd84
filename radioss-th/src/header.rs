//! The header of a T01 file: what is recorded (global variables, parts, materials, properties,
//! subsets, time-history groups and their elements), read record by record.

use crate::record::{Record, Records};
use crate::{Error, names};

/// Width of a title in the file.
const TITLE: usize = 40;

/// A part: its id, title and the ids of its recorded variables.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    pub id: i32,
    pub title: String,
    pub variables: Vec<i32>,
}

/// A material or property (shell section): id and title, listed by the file for reference.
#[derive(Debug, Clone, PartialEq)]
pub struct Named {
    pub id: i32,
    pub title: String,
}

/// A subset (the whole model is subset 0): its parts and recorded variables.
#[derive(Debug, Clone, PartialEq)]
pub struct Subset {
    pub id: i32,
    pub title: String,
    pub children: Vec<i32>,
    pub parts: Vec<i32>,
    pub variables: Vec<i32>,
}

/// A time-history group (`/TH/INTER`, `/TH/NODE`, ...): its kind, its elements (interfaces, nodes,
/// ...) and the variables recorded for each element.
#[derive(Debug, Clone, PartialEq)]
pub struct Group {
    pub id: i32,
    /// The group's type code: [`names::KIND_NODE`] for nodes, [`names::KIND_INTERFACE`] for
    /// interfaces; others are kept as read.
    pub kind: i32,
    pub title: String,
    pub elements: Vec<Named>,
    pub variables: Vec<i32>,
}

/// Everything before the first time step.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// The format version the file states (3040 for the build this crate was checked on).
    pub version: i32,
    pub title: String,
    /// The second record: date, program and platform.
    pub banner: String,
    pub globals: Vec<i32>,
    pub parts: Vec<Part>,
    pub materials: Vec<Named>,
    pub properties: Vec<Named>,
    pub subsets: Vec<Subset>,
    pub groups: Vec<Group>,
}

impl Header {
    pub(crate) fn read(r: &mut Records) -> Result<Header, Error> {
        let first = r.next_record("version and title")?;
        if first.bytes.len() < 4 {
            return Err(format_error(
                &first,
                "version and title",
                "shorter than its version number",
            ));
        }
        let banner = r.next_record("banner")?;
        let counts = r.words(6, "counts (parts, materials, properties, subsets, groups, globals)")?;
        let what = "counts";
        let [parts, materials, properties, subsets, groups, globals] =
            [0, 1, 2, 3, 4, 5].map(|i| counts.count(i, what));
        let globals = ids(r, globals?, "global variable ids")?;
        let parts = (0..parts?).map(|_| part(r)).collect::<Result<_, _>>()?;
        let materials = (0..materials?)
            .map(|_| named(r, "material"))
            .collect::<Result<_, _>>()?;
        let properties = (0..properties?)
            .map(|_| named(r, "property"))
            .collect::<Result<_, _>>()?;
        let subsets = (0..subsets?).map(|_| subset(r)).collect::<Result<_, _>>()?;
        let groups = (0..groups?).map(|_| group(r)).collect::<Result<_, _>>()?;
        Ok(Header {
            version: first.int(0),
            title: first.text(4, 80),
            banner: banner.text(0, banner.bytes.len()),
            globals,
            parts,
            materials,
            properties,
            subsets,
            groups,
        })
    }

    /// Values per time step in the parts' record.
    pub fn part_values(&self) -> usize {
        self.parts.iter().map(|p| p.variables.len()).sum()
    }

    /// Values per time step in the subsets' record.
    pub fn subset_values(&self) -> usize {
        self.subsets.iter().map(|s| s.variables.len()).sum()
    }
}

fn format_error(r: &Record, what: &str, detail: &str) -> Error {
    Error::Format {
        offset: r.offset,
        what: what.to_string(),
        detail: detail.to_string(),
    }
}

/// A record of `n` ids (none when `n` is 0: the file then writes no record).
fn ids(r: &mut Records, n: usize, what: &str) -> Result<Vec<i32>, Error> {
    if n == 0 {
        return Ok(Vec::new());
    }
    Ok(r.words(n, what)?.ints())
}

/// A record `[ints before] title(40) [ints after]`: the ints and the title.
fn titled(r: &mut Records, before: usize, after: usize, what: &str) -> Result<(Vec<i32>, String), Error> {
    let rec = r.next_record(what)?;
    let want = 4 * (before + after) + TITLE;
    if rec.bytes.len() != want {
        return Err(format_error(
            &rec,
            what,
            &format!(
                "expected {want} bytes ({before} integers, a {TITLE}-character title, {after} integers), found {}",
                rec.bytes.len()
            ),
        ));
    }
    let mut ints: Vec<i32> = (0..before).map(|i| rec.int(i)).collect();
    let title = rec.text(4 * before, TITLE);
    let tail = 4 * before + TITLE;
    ints.extend((0..after).map(|i| {
        let b = &rec.bytes[tail + 4 * i..tail + 4 * i + 4];
        i32::from_be_bytes([b[0], b[1], b[2], b[3]])
    }));
    Ok((ints, title))
}

fn count(v: i32, offset: usize, what: &str) -> Result<usize, Error> {
    usize::try_from(v).map_err(|_| Error::Format {
        offset,
        what: what.to_string(),
        detail: format!("negative count {v}"),
    })
}

/// A part: `[id] title [three ints] [nvar]`, then its variable ids.
fn part(r: &mut Records) -> Result<Part, Error> {
    let at = r.offset();
    let (ints, title) = titled(r, 1, 4, "part")?;
    let n = count(ints[4], at, "part")?;
    Ok(Part {
        id: ints[0],
        title,
        variables: ids(r, n, "part variable ids")?,
    })
}

fn named(r: &mut Records, what: &str) -> Result<Named, Error> {
    let (ints, title) = titled(r, 1, 0, what)?;
    Ok(Named { id: ints[0], title })
}

/// A subset: `[id, parent, subsets, parts, nvar] title`, then its subsets, parts and variables.
fn subset(r: &mut Records) -> Result<Subset, Error> {
    let at = r.offset();
    let (ints, title) = titled(r, 5, 0, "subset")?;
    let [children, parts, vars] = [2, 3, 4].map(|i| count(ints[i], at, "subset"));
    Ok(Subset {
        id: ints[0],
        title,
        children: ids(r, children?, "subset's subsets")?,
        parts: ids(r, parts?, "subset's parts")?,
        variables: ids(r, vars?, "subset's variable ids")?,
    })
}

/// A group: `[id, kind, _, elements, nvar] title`, a record `[id] title` per element, then the
/// variable ids.
fn group(r: &mut Records) -> Result<Group, Error> {
    let at = r.offset();
    let (ints, title) = titled(r, 5, 0, "time-history group")?;
    let [elements, vars] = [3, 4].map(|i| count(ints[i], at, "time-history group"));
    let elements = (0..elements?)
        .map(|_| named(r, "time-history group element"))
        .collect::<Result<_, _>>()?;
    Ok(Group {
        id: ints[0],
        kind: ints[1],
        title,
        elements,
        variables: ids(r, vars?, "group variable ids")?,
    })
}

impl Group {
    /// The name of the group's `k`-th variable (see [`names::group_variable`]).
    pub fn variable_name(&self, k: usize) -> String {
        names::group_variable(self.kind, self.variables[k])
    }
}
