//! Turns the blocks of a deck into a [`Model`]: which part is the tube, the striker, the base;
//! thicknesses, material, mass, velocity, times; wall length per tube part from the mesh.

use std::collections::HashMap;
use std::path::Path;

use super::model::{
    self, Binary, Contact, DeckError, Located, Model, Plastic, Reader, RunControl, Striker, TubeMesh, TubePart, card,
};
use lab::render::lsdyna::deck::{self, Card};

type Res<T> = Result<T, DeckError>;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Material {
    Plastic(Plastic),
    Rigid { rho: f64 },
}

#[derive(Debug, Clone)]
struct PartDef {
    pid: i64,
    title: String,
    secid: i64,
    mid: i64,
    file: String,
    line: usize,
}

/// Mesh geometry gathered from `*NODE` and `*ELEMENT_SHELL`.
#[derive(Default)]
struct Geometry {
    nodes: HashMap<i64, [f64; 3]>,
    area: HashMap<i64, f64>,
    count: HashMap<i64, usize>,
    part_nodes: HashMap<i64, Vec<i64>>,
    elements: usize,
    min_edge: f64,
}

/// Reads and checks the deck at `main`.
pub fn load(main: &Path) -> Res<Model> {
    let blocks = model::read_blocks(main)?;
    let r = model::parameters(&blocks)?;
    let materials = materials(&blocks, &r)?;
    let sections = sections(&blocks, &r)?;
    let parts = parts(&blocks, &r)?;
    let geo = geometry(&blocks)?;
    let (material, tube, length, diameter) = tube(&materials, &sections, &parts, &geo, main)?;
    let striker = striker(&blocks, &r, &materials, &sections, &parts, &geo, main)?;
    let base_pid = parts
        .iter()
        .find(|p| p.pid != striker.pid && matches!(materials.get(&p.mid), Some(Material::Rigid { .. })))
        .map(|p| p.pid);
    let (end_time, tssfac) = control(&blocks, &r, main)?;
    Ok(Model {
        title: first_text(&blocks, "TITLE").unwrap_or_else(|| "crushsim run".into()),
        params: r
            .order
            .iter()
            .filter_map(|k| r.params.get(k).map(|v| (k.clone(), v.clone())))
            .collect(),
        material,
        striker,
        base_pid,
        contacts: contacts(&blocks, &r)?,
        test_switch: test_switch(&blocks, &r)?,
        mesh: TubeMesh {
            tube,
            tube_length: length,
            tube_diameter: diameter,
            nodes: geo.nodes.len(),
            elements: geo.elements,
            min_edge: geo.min_edge,
        },
        run: RunControl {
            end_time,
            tssfac,
            dt_rcforc: database(&blocks, &r, "DATABASE_RCFORC")?,
            dt_glstat: database(&blocks, &r, "DATABASE_GLSTAT")?,
            dt_nodout: database(&blocks, &r, "DATABASE_NODOUT")?,
            binary: Binary {
                rcforc: binary(&blocks, &r, "DATABASE_RCFORC")?,
                glstat: binary(&blocks, &r, "DATABASE_GLSTAT")?,
                nodout: binary(&blocks, &r, "DATABASE_NODOUT")?,
            },
            history_nodes: history(&blocks, &r, &geo)?,
        },
    })
}

fn named<'a>(blocks: &'a [Located], keyword: &'a str) -> impl Iterator<Item = &'a Located> + 'a {
    blocks.iter().filter(move |b| b.block.keyword == keyword)
}

fn first_text(blocks: &[Located], keyword: &str) -> Option<String> {
    named(blocks, keyword)
        .next()
        .and_then(|b| b.block.cards.first())
        .map(|c| c.text.trim().to_string())
}

fn fail(file: &str, line: usize, message: impl Into<String>) -> DeckError {
    DeckError {
        file: file.to_string(),
        line,
        message: message.into(),
    }
}

fn positive(b: &Located, c: &Card, what: &str, v: f64) -> Res<f64> {
    if v > 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(fail(
            &b.file,
            c.line,
            format!("*{}: {what} must be positive, is {v}", b.block.keyword),
        ))
    }
}

fn materials(blocks: &[Located], r: &Reader) -> Res<HashMap<i64, Material>> {
    let mut out = HashMap::new();
    for b in blocks {
        let kw = b.block.keyword.as_str();
        let f = &b.file;
        if matches!(kw, "MAT_PLASTIC_KINEMATIC" | "MAT_003") {
            let (c1, c2) = (card(b, 0)?, card(b, 1)?);
            let m = Plastic {
                mid: r.int_or(f, c1, 0, 0)?,
                rho: positive(b, c1, "RO", r.real_or(f, c1, 1, 0.0)?)?,
                e: positive(b, c1, "E", r.real_or(f, c1, 2, 0.0)?)?,
                nu: r.real_or(f, c1, 3, 0.0)?,
                sigy: positive(b, c1, "SIGY", r.real_or(f, c1, 4, 0.0)?)?,
                etan: r.real_or(f, c1, 5, 0.0)?,
                beta: r.real_or(f, c1, 6, 0.0)?,
                src: r.real_or(f, c2, 0, 0.0)?,
                srp: r.real_or(f, c2, 1, 0.0)?,
            };
            if m.etan < 0.0 || m.src < 0.0 || m.srp < 0.0 || !(0.0..0.5).contains(&m.nu) {
                return Err(fail(
                    f,
                    c1.line,
                    "MAT_003: ETAN, SRC, SRP must be >= 0 and 0 <= PR < 0.5",
                ));
            }
            out.insert(m.mid, Material::Plastic(m));
        } else if matches!(kw, "MAT_RIGID" | "MAT_020") {
            let c1 = card(b, 0)?;
            out.insert(
                r.int_or(f, c1, 0, 0)?,
                Material::Rigid {
                    rho: r.real_or(f, c1, 1, 0.0)?,
                },
            );
        }
    }
    Ok(out)
}

fn sections(blocks: &[Located], r: &Reader) -> Res<HashMap<i64, f64>> {
    let mut out = HashMap::new();
    for b in named(blocks, "SECTION_SHELL") {
        let (c1, c2) = (card(b, 0)?, card(b, 1)?);
        let t = positive(b, c2, "T1", r.real_or(&b.file, c2, 0, 0.0)?)?;
        out.insert(r.int_or(&b.file, c1, 0, 0)?, t);
    }
    Ok(out)
}

fn parts(blocks: &[Located], r: &Reader) -> Res<Vec<PartDef>> {
    let mut out = Vec::new();
    for b in blocks
        .iter()
        .filter(|b| matches!(b.block.keyword.as_str(), "PART" | "PART_INERTIA"))
    {
        let (title, c) = (card(b, 0)?, card(b, 1)?);
        let f = &b.file;
        out.push(PartDef {
            pid: r.int_or(f, c, 0, 0)?,
            title: title.text.trim().to_string(),
            secid: r.int_or(f, c, 1, 0)?,
            mid: r.int_or(f, c, 2, 0)?,
            file: f.clone(),
            line: c.line,
        });
    }
    Ok(out)
}

fn geometry(blocks: &[Located]) -> Res<Geometry> {
    let mut g = Geometry {
        min_edge: f64::INFINITY,
        ..Default::default()
    };
    for b in named(blocks, "NODE") {
        for c in &b.block.cards {
            let f = deck::fields(&c.text, &[8, 16, 16, 16, 8, 8]);
            let num = |k: usize| f.get(k).and_then(|s| deck::parse_real(s));
            match (f.first().and_then(|s| deck::parse_int(s)), num(1), num(2), num(3)) {
                (Some(id), Some(x), Some(y), Some(z)) => {
                    g.nodes.insert(id, [x, y, z]);
                }
                _ => {
                    return Err(fail(
                        &b.file,
                        c.line,
                        format!("*NODE card {:?} is not `id x y z`", c.text.trim()),
                    ));
                }
            }
        }
    }
    for b in named(blocks, "ELEMENT_SHELL") {
        for c in &b.block.cards {
            shell(&mut g, &b.file, c)?;
        }
    }
    Ok(g)
}

fn shell(g: &mut Geometry, file: &str, c: &Card) -> Res<()> {
    let f = deck::fields(&c.text, &[8]);
    let ids: Option<Vec<i64>> = f.iter().take(6).map(|s| deck::parse_int(s)).collect();
    let ids = ids
        .filter(|v| v.len() == 6)
        .ok_or_else(|| fail(file, c.line, "*ELEMENT_SHELL card is not `eid pid n1 n2 n3 n4`"))?;
    let xyz: Option<Vec<[f64; 3]>> = ids[2..].iter().map(|n| g.nodes.get(n).copied()).collect();
    let xyz = xyz.ok_or_else(|| fail(file, c.line, format!("shell {} uses an undefined node", ids[0])))?;
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let cross = |u: [f64; 3], v: [f64; 3]| {
        [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ]
    };
    let area = 0.5 * norm(cross(sub(xyz[2], xyz[0]), sub(xyz[3], xyz[1])));
    for k in 0..4 {
        let e = norm(sub(xyz[(k + 1) % 4], xyz[k]));
        if e > 0.0 {
            g.min_edge = g.min_edge.min(e);
        }
    }
    *g.area.entry(ids[1]).or_default() += area;
    *g.count.entry(ids[1]).or_default() += 1;
    g.part_nodes.entry(ids[1]).or_default().extend_from_slice(&ids[2..]);
    g.elements += 1;
    Ok(())
}

type Tube = (Plastic, Vec<TubePart>, f64, f64);

fn tube(
    materials: &HashMap<i64, Material>,
    sections: &HashMap<i64, f64>,
    parts: &[PartDef],
    g: &Geometry,
    main: &Path,
) -> Res<Tube> {
    let deck = main.display().to_string();
    let plastic: Vec<&PartDef> = parts
        .iter()
        .filter(|p| matches!(materials.get(&p.mid), Some(Material::Plastic(_))))
        .collect();
    let Some(first) = plastic.first() else {
        return Err(fail(&deck, 0, "no part uses *MAT_PLASTIC_KINEMATIC: nothing to crush"));
    };
    let Some(Material::Plastic(material)) = materials.get(&first.mid).copied() else {
        unreachable_material(&deck)?
    };
    let (mut zmin, mut zmax, mut rmax) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
    for p in &plastic {
        for n in g.part_nodes.get(&p.pid).into_iter().flatten() {
            let [x, y, z] = g.nodes[n];
            (zmin, zmax, rmax) = (zmin.min(z), zmax.max(z), rmax.max(x.hypot(y)));
        }
    }
    let length = zmax - zmin;
    if length.is_nan() || length <= 0.0 {
        return Err(fail(&deck, 0, "the tube parts have no shells (is the mesh included?)"));
    }
    let mut tube = Vec::new();
    for p in plastic {
        let t = *sections.get(&p.secid).ok_or_else(|| {
            fail(
                &p.file,
                p.line,
                format!("part {}: section {} is not defined", p.pid, p.secid),
            )
        })?;
        let area = g.area.get(&p.pid).copied().unwrap_or(0.0);
        tube.push(TubePart {
            pid: p.pid,
            title: p.title.clone(),
            thickness: t,
            wall_length: area / length,
            elements: g.count.get(&p.pid).copied().unwrap_or(0),
        });
    }
    Ok((material, tube, length, 2.0 * rmax))
}

fn unreachable_material<T>(deck: &str) -> Res<T> {
    Err(fail(deck, 0, "internal: tube material vanished"))
}

fn striker(
    blocks: &[Located],
    r: &Reader,
    materials: &HashMap<i64, Material>,
    sections: &HashMap<i64, f64>,
    parts: &[PartDef],
    g: &Geometry,
    main: &Path,
) -> Res<Striker> {
    let deck = main.display().to_string();
    let motion = named(blocks, "BOUNDARY_PRESCRIBED_MOTION_RIGID").next();
    let inertia = named(blocks, "PART_INERTIA").next();
    let pid = match (motion, inertia) {
        (Some(b), _) => r.int_or(&b.file, card(b, 0)?, 0, 0)?,
        (None, Some(b)) => r.int_or(&b.file, card(b, 1)?, 0, 0)?,
        (None, None) => {
            return Err(fail(
                &deck,
                0,
                "no striker: need *PART_INERTIA or *BOUNDARY_PRESCRIBED_MOTION_RIGID on a rigid part",
            ));
        }
    };
    let part = parts
        .iter()
        .find(|p| p.pid == pid)
        .ok_or_else(|| fail(&deck, 0, format!("striker part {pid} is not defined")))?;
    let Some(Material::Rigid { rho }) = materials.get(&part.mid).copied() else {
        return Err(fail(
            &part.file,
            part.line,
            format!("striker part {pid} must use *MAT_RIGID"),
        ));
    };
    let mut s = Striker {
        pid,
        mass: 0.0,
        speed: 0.0,
        prescribed: None,
        node: None,
    };
    match inertia.filter(|b| r.int_or(&b.file, &b.block.cards[1], 0, 0).ok() == Some(pid)) {
        Some(b) => {
            let (c2, c4) = (card(b, 2)?, card(b, 4)?);
            s.mass = positive(b, c2, "TM", r.real_or(&b.file, c2, 3, 0.0)?)?;
            s.node = r.int(&b.file, c2, 5)?;
            s.speed = -r.real_or(&b.file, c4, 2, 0.0)?;
        }
        None => {
            s.mass = rho * g.area.get(&pid).copied().unwrap_or(0.0) * sections.get(&part.secid).copied().unwrap_or(0.0);
            // Driven by *BOUNDARY_PRESCRIBED_MOTION_RIGID alone: a *DATABASE_HISTORY_NODE on the
            // striker moves with it (the OpenRadioss template's striker).
            let on_striker = g.part_nodes.get(&pid);
            s.node = history(blocks, r, g)?
                .into_iter()
                .map(|(id, _)| id)
                .find(|id| on_striker.is_some_and(|nodes| nodes.contains(id)));
        }
    }
    if let Some(b) = motion {
        s.prescribed = Some(prescribed(blocks, r, b)?);
        s.speed = s.prescribed.as_ref().map(|c| c[0].1).unwrap_or(s.speed);
    }
    if s.mass <= 0.0 {
        return Err(fail(&deck, 0, format!("striker part {pid} has no mass")));
    }
    Ok(s)
}

/// The prescribed crushing speed as (time, speed) points, from the motion's curve and scale.
fn prescribed(blocks: &[Located], r: &Reader, b: &Located) -> Res<Vec<(f64, f64)>> {
    let c = card(b, 0)?;
    let f = &b.file;
    let (dof, vad, lcid, sf) = (
        r.int_or(f, c, 1, 0)?,
        r.int_or(f, c, 2, 0)?,
        r.int_or(f, c, 3, 0)?,
        r.real_or(f, c, 4, 1.0)?,
    );
    if dof != 3 || vad != 0 {
        return Err(fail(
            f,
            c.line,
            format!("crushsim supports prescribed z velocity only (DOF 3, VAD 0), not DOF {dof} VAD {vad}"),
        ));
    }
    let curve = named(blocks, "DEFINE_CURVE")
        .find(|cb| {
            cb.block
                .cards
                .first()
                .and_then(|c0| r.int(&cb.file, c0, 0).ok().flatten())
                == Some(lcid)
        })
        .ok_or_else(|| fail(f, c.line, format!("load curve {lcid} is not defined")))?;
    let c0 = card(curve, 0)?;
    let (sfa, sfo) = (r.real_or(&curve.file, c0, 2, 1.0)?, r.real_or(&curve.file, c0, 3, 1.0)?);
    let (sfa, sfo) = (if sfa == 0.0 { 1.0 } else { sfa }, if sfo == 0.0 { 1.0 } else { sfo });
    let mut points = Vec::new();
    for p in &curve.block.cards[1..] {
        let a = r.real_w(&curve.file, p, 0, &[20])?.unwrap_or(0.0);
        let o = r.real_w(&curve.file, p, 1, &[20])?.unwrap_or(0.0);
        points.push((a * sfa, -o * sfo * sf));
    }
    if points.is_empty() || points.windows(2).any(|w| w[1].0 <= w[0].0) {
        return Err(fail(
            &curve.file,
            c0.line,
            format!("load curve {lcid} needs increasing abscissae"),
        ));
    }
    Ok(points)
}

fn control(blocks: &[Located], r: &Reader, main: &Path) -> Res<(f64, f64)> {
    let b = named(blocks, "CONTROL_TERMINATION")
        .next()
        .ok_or_else(|| fail(&main.display().to_string(), 0, "no *CONTROL_TERMINATION"))?;
    let c = card(b, 0)?;
    let end = positive(b, c, "ENDTIM", r.real_or(&b.file, c, 0, 0.0)?)?;
    let tssfac = match named(blocks, "CONTROL_TIMESTEP").next() {
        Some(t) => r.real_or(&t.file, card(t, 0)?, 1, 0.9)?,
        None => 0.9,
    };
    Ok((end, if tssfac > 0.0 { tssfac } else { 0.9 }))
}

fn database(blocks: &[Located], r: &Reader, keyword: &str) -> Res<Option<f64>> {
    match named(blocks, keyword).next() {
        None => Ok(None),
        Some(b) => {
            let c = card(b, 0)?;
            Ok(Some(positive(b, c, "DT", r.real_or(&b.file, c, 0, 0.0)?)?))
        }
    }
}

/// The BINARY field (the second) of a `*DATABASE_...` card: 1 ASCII (blank or 0 too), 2 binout,
/// 3 both.
fn binary(blocks: &[Located], r: &Reader, keyword: &str) -> Res<i64> {
    let Some(b) = named(blocks, keyword).next() else {
        return Ok(1);
    };
    let c = card(b, 0)?;
    match r.int_or(&b.file, c, 1, 1)? {
        0 | 1 => Ok(1),
        v @ (2 | 3) => Ok(v),
        v => Err(fail(
            &b.file,
            c.line,
            format!("*{keyword}: BINARY is {v}, expected 1 (ASCII), 2 (binout) or 3 (both)"),
        )),
    }
}

fn history(blocks: &[Located], r: &Reader, g: &Geometry) -> Res<Vec<(i64, [f64; 3])>> {
    let mut out = Vec::new();
    for b in named(blocks, "DATABASE_HISTORY_NODE") {
        for c in &b.block.cards {
            for k in 0..8 {
                if let Some(id) = r.int(&b.file, c, k)?.filter(|&id| id > 0) {
                    let xyz = g
                        .nodes
                        .get(&id)
                        .ok_or_else(|| fail(&b.file, c.line, format!("history node {id} is not defined")))?;
                    out.push((id, *xyz));
                }
            }
        }
    }
    Ok(out)
}

fn contacts(blocks: &[Located], r: &Reader) -> Res<Vec<Contact>> {
    let mut out = Vec::new();
    for b in blocks.iter().filter(|b| b.block.keyword.starts_with("CONTACT_")) {
        let (c1, c2) = (card(b, 0)?, card(b, 1)?);
        let f = &b.file;
        let (msid, mstyp) = (r.int_or(f, c1, 1, 0)?, r.int_or(f, c1, 3, 0)?);
        out.push(Contact {
            kind: b.block.keyword.clone(),
            ssid: r.int_or(f, c1, 0, 0)?,
            msid,
            fs: r.real_or(f, c2, 0, 0.0)?,
            master_part: (mstyp == 3).then_some(msid),
        });
    }
    Ok(out)
}

fn test_switch(blocks: &[Located], r: &Reader) -> Res<Option<(String, f64)>> {
    let Some(b) = named(blocks, "CRUSHSIM_TEST").next() else {
        return Ok(None);
    };
    let c = card(b, 0)?;
    let mode = deck::fields(&c.text, &[10])
        .first()
        .map(|s| s.trim().to_ascii_lowercase())
        .unwrap_or_default();
    Ok(Some((mode, r.real_or(&b.file, c, 1, 0.0)?)))
}
