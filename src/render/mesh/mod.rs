//! A honeycomb-tube mesher: the shell mesh of a cylinder cut from hexagonal honeycomb.
//!
//! Geometry (x, y in the cross-section, z along the tube, origin at the tube's axis on the base):
//! - hexagonal cells of size `c` across flats, side `s = c/√3`, cell centres on the lattice
//!   `(1.5 s i, c j + c/2 (i mod 2))`, one cell centred on the axis;
//! - the walls parallel to x are the *ribbon* walls: in expanded honeycomb these are where two
//!   foil strips are glued, i.e. the bonded double-thickness walls (one of the three orientations,
//!   a third of the wall length); they are part [`PART_RIBBON`], the other walls part [`PART_SINGLE`];
//! - the lattice is cut by the cylinder of diameter `D` (57.35 mm): walls crossing it are trimmed
//!   at the circle (a cut within a quarter element of a lattice vertex snaps to the vertex, so
//!   walls meeting there still share a node); trimmed pieces shorter than a quarter of the element size are dropped (their
//!   length is reported), so no element is much thinner than it is tall;
//! - the walls are extruded over the length `L` (150 mm) and meshed with 4-node shells of about
//!   `h` (0.5 mm in the paper): each wall piece gets `max(1, round(len/h))` elements across,
//!   the length `max(1, round(L/h))` elements.
//!
//! The nodes where the circle cut a wall (its free edges at the specimen's boundary, on every
//! layer) can be listed as a node set ([`Mesh::edge_set`], [`include_with_edge_set`]) for a
//! template to hold them, as if the honeycomb went on beyond the cut.
//!
//! Nodes at wall junctions are shared (one in-plane point per lattice vertex, whatever the number
//! of walls meeting there), so there are no duplicate nodes. Node and element ids start at 1 and
//! stay below [`FIRST_FREE_ID`], which templates use for the striker and the base.
//!
//! Reference formulas (used by the tests): cell area `A_cell = (√3/2) c²`; wall length per unit
//! cross-section area `3 s / A_cell = 2/c`, a third of it ribbon walls; so for the tube
//! `cells ≈ (π D²/4) / A_cell` and `wall length ≈ (π D²/4) · 2/c`.

mod fixed;

use std::collections::HashMap;
use std::fmt::{self, Write};

/// Part id of the single-thickness walls.
pub const PART_SINGLE: u32 = 1;
/// Part id of the ribbon-direction (bonded double) walls.
pub const PART_RIBBON: u32 = 2;
/// The first node/element id left free for the rest of the deck.
pub const FIRST_FREE_ID: usize = 9_000_001;

/// What to mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TubeSpec {
    /// Cell size across flats, mm.
    pub cell: f64,
    /// Tube diameter, mm.
    pub diameter: f64,
    /// Tube length, mm.
    pub length: f64,
    /// Target element size, mm.
    pub element: f64,
}

impl TubeSpec {
    /// The paper's tube (57.35 mm × 150 mm) with cell size `cell` and element size `element`.
    pub fn paper(cell: f64, element: f64) -> Self {
        TubeSpec {
            cell,
            diameter: 57.35,
            length: 150.0,
            element,
        }
    }
}

/// A spec the mesher refuses.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshError(pub String);

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "honeycomb mesh: {}", self.0)
    }
}

impl std::error::Error for MeshError {}

/// One wall piece in the cross-section: its chain of in-plane points (ends included).
#[derive(Debug, Clone, PartialEq)]
pub struct Wall {
    pub points: Vec<usize>,
    pub part: u32,
    pub length: f64,
}

/// The mesh: in-plane points and wall chains, extruded in `levels` node layers along z.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    pub spec: TubeSpec,
    pub points: Vec<[f64; 2]>,
    pub walls: Vec<Wall>,
    /// Number of element rows along the tube.
    pub rows: usize,
    /// Cells whose centre lies inside the tube.
    pub cells: usize,
    /// Total length of trimmed fragments dropped as too short, mm.
    pub dropped_length: f64,
    /// In-plane points where the circle cut a wall (ascending).
    pub cut_points: Vec<usize>,
}

/// Counts and quality of a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    pub cells: usize,
    /// Cross-section wall length of the single walls (part 1) and ribbon walls (part 2), mm.
    pub wall_length_single: f64,
    pub wall_length_ribbon: f64,
    pub dropped_length: f64,
    pub nodes: usize,
    pub elements: usize,
    pub elements_single: usize,
    pub elements_ribbon: usize,
    /// Longest over shortest side of the elements.
    pub min_aspect: f64,
    pub max_aspect: f64,
}

/// Meshes the tube.
pub fn mesh(spec: &TubeSpec) -> Result<Mesh, MeshError> {
    check(spec)?;
    let mut points = PointSet::new(spec);
    let mut walls = Vec::new();
    let mut dropped = 0.0;
    let (edges, cells) = lattice_edges(spec);
    for (p, q) in edges {
        let Some((a, b)) = clip(p, q, spec) else { continue };
        let len = dist(points.xy(a), points.xy(b));
        if len < 0.25 * spec.element {
            dropped += len;
            continue;
        }
        walls.push(chain(&mut points, a, b, p.1 == q.1, spec.element));
    }
    let rows = ((spec.length / spec.element).round() as usize).max(1);
    let mut cut_points = points.cuts;
    cut_points.sort_unstable();
    let mesh = Mesh {
        spec: *spec,
        points: points.coords,
        walls,
        rows,
        cells,
        dropped_length: dropped,
        cut_points,
    };
    if mesh.node_count() >= FIRST_FREE_ID || mesh.element_count() >= FIRST_FREE_ID {
        return Err(MeshError(format!(
            "{} nodes: too many for ids below {FIRST_FREE_ID}",
            mesh.node_count()
        )));
    }
    Ok(mesh)
}

/// The LS-DYNA include (`*NODE`, `*ELEMENT_SHELL`, fixed format) and the summary, for one design.
pub fn include(spec: &TubeSpec) -> Result<(String, Summary), MeshError> {
    let mesh = mesh(spec)?;
    Ok((mesh.include(), mesh.summary()))
}

/// [`include`] with the cut edges' nodes as `*SET_NODE_LIST` `set` ([`Mesh::edge_set`]) before
/// its `*END`.
pub fn include_with_edge_set(spec: &TubeSpec, set: u32) -> Result<(String, Summary), MeshError> {
    let mesh = mesh(spec)?;
    let mut text = mesh.include();
    let end = text.len() - "*END\n".len();
    text.insert_str(end, &mesh.edge_set(set));
    Ok((text, mesh.summary()))
}

fn check(spec: &TubeSpec) -> Result<(), MeshError> {
    let all = [spec.cell, spec.diameter, spec.length, spec.element];
    if all.iter().any(|v| !v.is_finite() || *v <= 0.0) {
        return Err(MeshError(format!("sizes must be positive: {spec:?}")));
    }
    if spec.cell >= spec.diameter || spec.element > spec.length {
        return Err(MeshError(format!("cell or element larger than the tube: {spec:?}")));
    }
    Ok(())
}

/// A lattice vertex in units of `(s/2, c/2)`: exact, so shared vertices are found exactly.
type Vertex = (i64, i64);

/// All distinct lattice edges of the cells that can touch the circle, and the number of cells
/// whose centre is inside it.
fn lattice_edges(spec: &TubeSpec) -> (Vec<(Vertex, Vertex)>, usize) {
    const CORNERS: [(i64, i64); 6] = [(2, 0), (1, 1), (-1, 1), (-2, 0), (-1, -1), (1, -1)];
    let (c, s, r) = (spec.cell, spec.cell / 3f64.sqrt(), spec.diameter / 2.0);
    let ni = (r / (1.5 * s)).ceil() as i64 + 1;
    let nj = (r / c).ceil() as i64 + 1;
    let mut seen = HashMap::new();
    let mut edges = Vec::new();
    let mut cells = 0;
    for i in -ni..=ni {
        for j in -nj..=nj {
            let centre = (3 * i, 2 * j + i.rem_euclid(2));
            let d = (centre.0 as f64 * s / 2.0).hypot(centre.1 as f64 * c / 2.0);
            if d > r + s {
                continue;
            }
            cells += usize::from(d < r);
            for k in 0..6 {
                let p = (centre.0 + CORNERS[k].0, centre.1 + CORNERS[k].1);
                let q = (centre.0 + CORNERS[(k + 1) % 6].0, centre.1 + CORNERS[(k + 1) % 6].1);
                let key = if p <= q { (p, q) } else { (q, p) };
                if seen.insert(key, ()).is_none() {
                    edges.push(key);
                }
            }
        }
    }
    (edges, cells)
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// An end of a clipped wall: a lattice vertex (shared) or a point where the circle cut the wall.
#[derive(Debug, Clone, Copy)]
enum End {
    Vertex(Vertex),
    Cut([f64; 2]),
}

/// The part of lattice edge `p`–`q` inside the circle of radius `r` about the origin.
fn clip(p: Vertex, q: Vertex, spec: &TubeSpec) -> Option<(End, End)> {
    let (hs, hc) = (spec.cell / 3f64.sqrt() / 2.0, spec.cell / 2.0);
    let (pf, qf) = ([p.0 as f64 * hs, p.1 as f64 * hc], [q.0 as f64 * hs, q.1 as f64 * hc]);
    let r = spec.diameter / 2.0;
    let d = [qf[0] - pf[0], qf[1] - pf[1]];
    let a = d[0] * d[0] + d[1] * d[1];
    let b = 2.0 * (pf[0] * d[0] + pf[1] * d[1]);
    let c = pf[0] * pf[0] + pf[1] * pf[1] - r * r;
    let disc = b * b - 4.0 * a * c;
    if disc <= 0.0 {
        return None;
    }
    let root = disc.sqrt();
    let lo = ((-b - root) / (2.0 * a)).max(0.0);
    let hi = ((-b + root) / (2.0 * a)).min(1.0);
    if hi <= lo {
        return None;
    }
    // A cut within a quarter element of a vertex snaps to it, so walls meeting there share a node.
    let snap = 0.25 * spec.element / a.sqrt();
    let lo = if lo < snap { 0.0 } else { lo };
    let hi = if 1.0 - hi < snap { 1.0 } else { hi };
    let at = |u: f64, v: Vertex| {
        if u == 0.0 || u == 1.0 {
            End::Vertex(v)
        } else {
            End::Cut([pf[0] + u * d[0], pf[1] + u * d[1]])
        }
    };
    Some((at(lo, p), at(hi, q)))
}

/// In-plane points; lattice vertices are stored once, so junctions share their node.
struct PointSet {
    coords: Vec<[f64; 2]>,
    /// Points made where the circle cut a wall.
    cuts: Vec<usize>,
    vertices: HashMap<Vertex, usize>,
    half_side: f64,
    half_cell: f64,
}

impl PointSet {
    fn new(spec: &TubeSpec) -> Self {
        PointSet {
            coords: Vec::new(),
            cuts: Vec::new(),
            vertices: HashMap::new(),
            half_side: spec.cell / 3f64.sqrt() / 2.0,
            half_cell: spec.cell / 2.0,
        }
    }

    fn xy(&self, end: End) -> [f64; 2] {
        match end {
            End::Vertex(v) => [v.0 as f64 * self.half_side, v.1 as f64 * self.half_cell],
            End::Cut(p) => p,
        }
    }

    fn get(&mut self, end: End) -> usize {
        match end {
            End::Vertex(v) => match self.vertices.get(&v) {
                Some(&id) => id,
                None => {
                    let id = self.push(self.xy(end));
                    self.vertices.insert(v, id);
                    id
                }
            },
            End::Cut(p) => {
                let id = self.push(p);
                self.cuts.push(id);
                id
            }
        }
    }

    fn push(&mut self, p: [f64; 2]) -> usize {
        self.coords.push(p);
        self.coords.len() - 1
    }
}

fn chain(points: &mut PointSet, a: End, b: End, ribbon: bool, h: f64) -> Wall {
    let (pa, pb) = (points.xy(a), points.xy(b));
    let len = dist(pa, pb);
    let n = ((len / h).round() as usize).max(1);
    let mut chain = vec![points.get(a)];
    for k in 1..n {
        let u = k as f64 / n as f64;
        chain.push(points.push([pa[0] + u * (pb[0] - pa[0]), pa[1] + u * (pb[1] - pa[1])]));
    }
    chain.push(points.get(b));
    Wall {
        points: chain,
        part: if ribbon { PART_RIBBON } else { PART_SINGLE },
        length: len,
    }
}

impl Mesh {
    /// Axial spacing of the node layers, mm.
    pub fn dz(&self) -> f64 {
        self.spec.length / self.rows as f64
    }

    pub fn node_count(&self) -> usize {
        self.points.len() * (self.rows + 1)
    }

    pub fn element_count(&self) -> usize {
        self.walls.iter().map(|w| w.points.len() - 1).sum::<usize>() * self.rows
    }

    /// Node id of in-plane point `p` on layer `k` (layer-major: the base layer is 1..=points).
    pub fn node_id(&self, p: usize, k: usize) -> usize {
        k * self.points.len() + p + 1
    }

    /// Coordinates of every node, in id order.
    pub fn nodes(&self) -> impl Iterator<Item = (usize, [f64; 3])> + '_ {
        let dz = self.dz();
        (0..=self.rows).flat_map(move |k| {
            self.points
                .iter()
                .enumerate()
                .map(move |(p, xy)| (self.node_id(p, k), [xy[0], xy[1], k as f64 * dz]))
        })
    }

    /// Every shell: (element id, part, four node ids counter-clockwise seen from the wall normal).
    pub fn elements(&self) -> impl Iterator<Item = (usize, u32, [usize; 4])> + '_ {
        let per_row: Vec<(u32, usize, usize)> = self
            .walls
            .iter()
            .flat_map(|w| w.points.windows(2).map(move |pq| (w.part, pq[0], pq[1])))
            .collect();
        let n = per_row.len();
        (0..self.rows).flat_map(move |k| {
            let row = per_row.clone();
            row.into_iter().enumerate().map(move |(e, (part, p, q))| {
                let ids = [
                    self.node_id(p, k),
                    self.node_id(q, k),
                    self.node_id(q, k + 1),
                    self.node_id(p, k + 1),
                ];
                (k * n + e + 1, part, ids)
            })
        })
    }

    pub fn summary(&self) -> Summary {
        let len = |part| {
            self.walls
                .iter()
                .filter(|w| w.part == part)
                .map(|w| w.length)
                .sum::<f64>()
        };
        let count = |part| {
            self.walls
                .iter()
                .filter(|w| w.part == part)
                .map(|w| w.points.len() - 1)
                .sum::<usize>()
        };
        let dz = self.dz();
        let aspects = self.walls.iter().map(|w| {
            let width = w.length / (w.points.len() - 1) as f64;
            width.max(dz) / width.min(dz)
        });
        let (min_aspect, max_aspect) = aspects.fold((f64::INFINITY, 0.0f64), |(lo, hi), a| (lo.min(a), hi.max(a)));
        Summary {
            cells: self.cells,
            wall_length_single: len(PART_SINGLE),
            wall_length_ribbon: len(PART_RIBBON),
            dropped_length: self.dropped_length,
            nodes: self.node_count(),
            elements: self.element_count(),
            elements_single: count(PART_SINGLE) * self.rows,
            elements_ribbon: count(PART_RIBBON) * self.rows,
            min_aspect,
            max_aspect,
        }
    }

    /// The node ids of the cut edges, on every layer, ascending.
    pub fn edge_nodes(&self) -> Vec<usize> {
        let mut ids: Vec<usize> = (0..=self.rows)
            .flat_map(|k| self.cut_points.iter().map(move |&p| self.node_id(p, k)))
            .collect();
        ids.sort_unstable();
        ids
    }

    /// `*SET_NODE_LIST` number `set` of [`Mesh::edge_nodes`] (8 ids of 10 characters a line).
    pub fn edge_set(&self, set: u32) -> String {
        let ids = self.edge_nodes();
        let mut out = format!(
            "$ the {} nodes where the cylinder cut the walls\n*SET_NODE_LIST\n$      sid\n{set:>10}\n",
            ids.len()
        );
        for line in ids.chunks(8) {
            for id in line {
                let _ = write!(out, "{id:>10}");
            }
            out.push('\n');
        }
        out
    }

    /// The include text: a comment header with the summary, `*NODE` (I8, 3×E16, I8, I8) and
    /// `*ELEMENT_SHELL` (I8 fields), `*END` last.
    pub fn include(&self) -> String {
        let mut out = String::with_capacity(64 * self.node_count() + 50 * self.element_count() + 1024);
        self.header(&mut out);
        out.push_str("*NODE\n$    nid               x               y               z      tc      rc\n");
        for (id, [x, y, z]) in self.nodes() {
            fixed::push_int(&mut out, id, 8);
            for v in [x, y, z] {
                fixed::push_fixed9(&mut out, v, 16);
            }
            out.push_str("       0       0\n");
        }
        out.push_str("*ELEMENT_SHELL\n$    eid     pid      n1      n2      n3      n4\n");
        for (id, part, nodes) in self.elements() {
            fixed::push_int(&mut out, id, 8);
            fixed::push_int(&mut out, part, 8);
            for n in nodes {
                fixed::push_int(&mut out, n, 8);
            }
            out.push('\n');
        }
        out.push_str("*END\n");
        out
    }

    fn header(&self, out: &mut String) {
        let s = self.summary();
        let sp = &self.spec;
        out.push_str("*KEYWORD\n");
        let _ = writeln!(
            out,
            "$ honeycomb tube: cell {} mm across flats, D {} mm, L {} mm",
            sp.cell, sp.diameter, sp.length
        );
        let _ = writeln!(
            out,
            "$ element size {} mm: {} nodes, {} shells",
            sp.element, s.nodes, s.elements
        );
        let _ = writeln!(out, "$ cells (centre inside) {}", s.cells);
        let _ = writeln!(
            out,
            "$ part {PART_SINGLE} single walls: {:.3} mm, {} shells",
            s.wall_length_single, s.elements_single
        );
        let _ = writeln!(
            out,
            "$ part {PART_RIBBON} ribbon walls: {:.3} mm, {} shells",
            s.wall_length_ribbon, s.elements_ribbon
        );
        let _ = writeln!(out, "$ dropped trimmed fragments: {:.3} mm", s.dropped_length);
        let _ = writeln!(out, "$ element aspect ratio {:.3} .. {:.3}", s.min_aspect, s.max_aspect);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `*NODE` and `*ELEMENT_SHELL` lines as `format!` writes them (the run keys of every
    /// recording hang on these bytes).
    fn by_format(m: &Mesh) -> String {
        let mut out = String::new();
        for (id, [x, y, z]) in m.nodes() {
            let _ = writeln!(out, "{id:8}{x:16.9}{y:16.9}{z:16.9}{:8}{:8}", 0, 0);
        }
        for (id, part, [a, b, c, d]) in m.elements() {
            let _ = writeln!(out, "{id:8}{part:8}{a:8}{b:8}{c:8}{d:8}");
        }
        out
    }

    #[test]
    fn the_include_text_is_what_format_writes() {
        for (cell, element) in [(3.0, 2.0), (6.0, 2.0), (4.5, 3.0)] {
            let m = mesh(&TubeSpec::paper(cell, element)).unwrap();
            let text = m.include();
            let data: String = text
                .lines()
                .filter(|l| !l.starts_with(['*', '$']))
                .map(|l| format!("{l}\n"))
                .collect();
            assert_eq!(data, by_format(&m), "cell {cell}, element {element}");
        }
    }

    #[test]
    fn the_edge_set_lists_every_cut_node_on_the_circle() {
        let spec = TubeSpec {
            cell: 6.0,
            diameter: 10.0,
            length: 8.0,
            element: 0.35,
        };
        let m = mesh(&spec).unwrap();
        // One cell about the axis; its six spokes cut at r = 5 (the rest of the lattice is outside).
        assert_eq!(m.cut_points.len(), 6);
        let coords: std::collections::HashMap<usize, [f64; 3]> = m.nodes().collect();
        let edge = m.edge_nodes();
        assert_eq!(edge.len(), 6 * (m.rows + 1));
        for id in &edge {
            let [x, y, _] = coords[id];
            assert!((x.hypot(y) - 5.0).abs() < 1e-9, "node {id} at r = {}", x.hypot(y));
        }
        let (text, _) = include_with_edge_set(&spec, 2).unwrap();
        let plain = include(&spec).unwrap().0;
        assert!(text.starts_with(&plain[..plain.len() - 5]) && text.ends_with("*END\n"));
        let listed: Vec<usize> = text
            .lines()
            .skip_while(|l| *l != "*SET_NODE_LIST")
            .skip(3)
            .take_while(|l| !l.starts_with('*'))
            .flat_map(|l| l.split_whitespace().map(|w| w.parse::<usize>().unwrap()))
            .collect();
        assert_eq!(listed, edge);
    }
}
