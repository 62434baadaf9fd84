//! The crush model: super-folding-element theory of hexagonal honeycomb, applied to the walls
//! the deck actually has.
//!
//! **Mean force.** Wierzbicki (1983) gives for one Y junction of expanded honeycomb (two single
//! flanges of thickness t and one bonded double flange 2t, each of length s/2)
//! `P = 8.61 σ0 t^(5/3) s^(1/3)`; with two junctions per cell of area `(3√3/2) s²` this is
//! `σm = 6.6 σ0 (t/s)^(5/3) = 16.5 σ0 (t/D)^(5/3)` with `D = √3 s` the cell size across flats.
//! To count walls that are actually present we split the junction force over its flanges in
//! proportion to `t_f^(5/3)` (each flange's folding energy scales as `σ0 t_f^(5/3) s^(1/3)` at a
//! given fold geometry): `P = κ σ0 s^(1/3) Σ_f t_f^(5/3)` with `κ = 8.61 / (2 + 2^(5/3)) = 1.664`.
//! A flange is s/2 long, so per unit wall length the force is `2κ σ0 s^(-2/3) t^(5/3)` and
//!
//! `F_m = 2κ σ0 s^(-2/3) Σ_parts ℓ_p t_p^(5/3)`,
//!
//! with `ℓ_p` the cross-section wall length of tube part p (shell area / tube length, from the
//! mesh) and `t_p` its section thickness. The cell side comes from the mesh too: a hexagonal
//! lattice has wall length 2/(√3 s) per unit area, so `s = 2A / (√3 Σ ℓ_p)`, `A = π D_tube²/4`
//! (D_tube from the largest node radius) — unless the deck states the cell size in a `CELL`
//! parameter, which is exact (the mesh estimate is ~1 % high: boundary walls snap outwards).
//! With the ribbon walls doubled this reproduces `16.5 σ0 (t/D)^(5/3) A`; with them single
//! (thickness t), the ribbon third of the walls carries `1/2^(5/3)` of its doubled share, so the
//! force drops by the factor `3 / (2 + 2^(5/3)) = 0.58`.
//!
//! **Flow stress.** Linear hardening (MAT_003's tangent modulus ETAN) raises the stress in the
//! fold hinges from σy at first yield to `σu = σy + ETAN ε` at the hinge strain ε; the flow stress
//! of the super-folding element is their mean, `σ0 = (σy + σu)/2 = σy + ETAN ε/2`. The hinge
//! strain follows the fold geometry: a wall of thickness t bent over a fold of half-wavelength
//! `H = 0.82 t^(1/3) s^(2/3)` reaches a mean surface strain of about `ε ≈ t/H` (bending radius of
//! the order of H), so
//!
//! `σ0 = σy + ETAN · t / (2H)`, with t the thinnest tube wall.
//!
//! Because ε depends on t and s, hardening is not a shift of the yield stress: with
//! ETAN = 200 MPa and σy = 185 MPa it raises the mean force by about 3.9 % for C6T5
//! (ε = 0.072), 8.5 % for C3T8 (ε = 0.157). Cowper–Symonds (SRC = C, SRP = p, both > 0):
//! `σ0 ← σ0 (1 + (ε̇/C)^(1/p))` with the mean hinge strain rate `ε̇ = 0.33 V / s` (the
//! Abramowicz–Jones estimate for a folding wall of width s crushed at speed V).
//!
//! **History.** Elastic rise with stiffness `K = E Σ ℓ_p t_p / L` up to the initial peak
//! `P_peak = Σ ℓ_p t_p σc,p`, `σc,p = min(σy', √(σcr,p σy'))` (plate buckling
//! `σcr = 4π²E/(12(1−ν²)) (t_p/s)²`, σy' = σy with the rate factor), at least 1.1 F_m; then the
//! peak decays over a third of a fold half-wavelength `H = 0.82 t^(1/3) s^(2/3)` into fold
//! oscillations `F_m (1 + 0.10 sin(2π u/λ) + 0.05 sin(2π u/(1.618 λ)))` with the fold period
//! `λ = 0.73 · 2H` (effective crush distance); densification multiplies the force by
//! `1 + 0.1 (ε/ε_D)^8 ε_D / max(ε_D − ε, 0.02)` at crush strain ε, `ε_D = 1 − 1.4 ρ_rel`,
//! `ρ_rel = Σ ℓ_p t_p / A`. Unloading is elastic with K. The striker either follows its
//! prescribed speed curve or, free, decelerates under the force (m dv/dt = −F).

use std::f64::consts::PI;

use super::model::Model;

/// κ: the Y-junction coefficient per unit `t^(5/3)` of flange.
pub fn kappa() -> f64 {
    8.61 / (2.0 + 2f64.powf(5.0 / 3.0))
}

/// The cell size the deck states in its `CELL` parameter (the template writes it; LS-DYNA
/// ignores unused parameters), if any.
pub fn cell_parameter(m: &Model) -> Option<f64> {
    m.params
        .iter()
        .find(|(k, _)| k == "CELL")
        .and_then(|(_, v)| v.as_f64())
        .filter(|c| *c > 0.0)
}

/// Quantities of the crush model that do not change during the run.
#[derive(Debug, Clone, PartialEq)]
pub struct Theory {
    pub area: f64,
    pub cell_side: f64,
    pub cell_size: f64,
    pub flow_stress: f64,
    /// Mean hinge strain `t/H` (thinnest wall over the fold half-wavelength).
    pub hinge_strain: f64,
    /// Σ ℓ_p t_p^(5/3), mm^(8/3).
    pub wall_sum: f64,
    pub wall_area: f64,
    pub stiffness: f64,
    /// The folds: half-wavelength, period, and the relative density that sets where they lock up.
    pub folds: Folding,
}

/// The folds: half-wavelength, period, and the relative density that sets where they lock up.
#[derive(Debug, Clone, PartialEq)]
pub struct Folding {
    pub half_wave: f64,
    pub fold_period: f64,
    pub rel_density: f64,
    pub eps_d: f64,
}

impl Theory {
    pub fn new(m: &Model) -> Self {
        let area = PI / 4.0 * m.mesh.tube_diameter.powi(2);
        let total: f64 = m.mesh.tube.iter().map(|p| p.wall_length).sum();
        let from_mesh = 2.0 * area / (3f64.sqrt() * total.max(f64::MIN_POSITIVE));
        let s = cell_parameter(m).map_or(from_mesh, |c| c / 3f64.sqrt());
        let wall_sum = m
            .mesh
            .tube
            .iter()
            .map(|p| p.wall_length * p.thickness.powf(5.0 / 3.0))
            .sum();
        let wall_area: f64 = m.mesh.tube.iter().map(|p| p.wall_length * p.thickness).sum();
        let t_ref = m.mesh.tube.iter().map(|p| p.thickness).fold(f64::INFINITY, f64::min);
        let half_wave = 0.82 * t_ref.cbrt() * s.powf(2.0 / 3.0);
        let rel_density = wall_area / area;
        let hinge_strain = t_ref / half_wave;
        Theory {
            area,
            cell_side: s,
            cell_size: 3f64.sqrt() * s,
            flow_stress: m.material.sigy + 0.5 * m.material.etan * hinge_strain,
            hinge_strain,
            wall_sum,
            wall_area,
            stiffness: m.material.e * wall_area / m.mesh.tube_length,
            folds: Folding {
                half_wave,
                fold_period: 0.73 * 2.0 * half_wave,
                rel_density,
                eps_d: (1.0 - 1.4 * rel_density).max(0.3),
            },
        }
    }

    /// Cowper–Symonds factor at crushing speed `v` (1 without SRC/SRP).
    pub fn rate_factor(&self, m: &Model, v: f64) -> f64 {
        let (c, p) = (m.material.src, m.material.srp);
        if c <= 0.0 || p <= 0.0 || v <= 0.0 {
            return 1.0;
        }
        1.0 + (0.33 * v / self.cell_side / c).powf(1.0 / p)
    }

    /// Mean crush force at speed `v`, N.
    pub fn mean_force(&self, m: &Model, v: f64) -> f64 {
        2.0 * kappa() * self.flow_stress * self.rate_factor(m, v) * self.cell_side.powf(-2.0 / 3.0) * self.wall_sum
    }

    /// The initial peak force at speed `v`, N.
    pub fn peak_force(&self, m: &Model, v: f64) -> f64 {
        let sy = m.material.sigy * self.rate_factor(m, v);
        let plate = 4.0 * PI * PI * m.material.e / (12.0 * (1.0 - m.material.nu.powi(2)));
        let peak: f64 = m
            .mesh
            .tube
            .iter()
            .map(|p| {
                let crit = plate * (p.thickness / self.cell_side).powi(2);
                p.wall_length * p.thickness * sy.min((crit * sy).sqrt())
            })
            .sum();
        peak.max(1.1 * self.mean_force(m, v))
    }

    /// The loading-branch force at crush `d` (mm) and speed `v`.
    pub fn loading_force(&self, m: &Model, d: f64, v: f64) -> f64 {
        let peak = self.peak_force(m, v);
        let d_e = peak / self.stiffness;
        if d <= d_e {
            return self.stiffness * d.max(0.0);
        }
        let u = d - d_e;
        let fm = self.mean_force(m, v);
        let lambda = self.folds.fold_period;
        let folds = 1.0 + 0.10 * (2.0 * PI * u / lambda).sin() + 0.05 * (2.0 * PI * u / (1.618 * lambda)).sin();
        let decay = (peak - fm) * (-u / (self.folds.half_wave / 3.0)).exp();
        (fm * folds + decay) * self.densification(d / m.mesh.tube_length)
    }

    fn densification(&self, eps: f64) -> f64 {
        let ed = self.folds.eps_d;
        1.0 + 0.1 * (eps.max(0.0) / ed).powi(8) * ed / (ed - eps).max(0.02)
    }
}

/// The state at one time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Step {
    pub time: f64,
    /// Crush (striker travel towards the base), mm.
    pub crush: f64,
    /// Crushing speed, mm/s.
    pub speed: f64,
    /// Crushing acceleration, mm/s².
    pub accel: f64,
    /// Contact force between striker and tube, N.
    pub force: f64,
    /// Work done on the tube, N·mm.
    pub internal: f64,
    /// Work done by the prescribed motion, N·mm.
    pub external: f64,
    pub kinetic: f64,
}

/// The run: steps every `dt` from 0 to the termination time.
#[derive(Debug, Clone, PartialEq)]
pub struct History {
    pub theory: Theory,
    pub dt: f64,
    pub steps: Vec<Step>,
}

impl History {
    /// The step nearest to `time`.
    pub fn at(&self, time: f64) -> &Step {
        let k = ((time / self.dt).round() as usize).min(self.steps.len() - 1);
        &self.steps[k]
    }

    /// Mean force over crush in `[from, to]` mm: absorbed energy / stroke.
    pub fn mean_force(&self, from: f64, to: f64) -> Option<f64> {
        let at = |d: f64| self.steps.iter().find(|s| s.crush >= d).map(|s| (s.crush, s.internal));
        let ((d0, e0), (d1, e1)) = (at(from)?, at(to)?);
        (d1 > d0).then(|| (e1 - e0) / (d1 - d0))
    }
}

/// Speed from a piecewise-linear curve (constant beyond its ends).
fn curve_at(points: &[(f64, f64)], t: f64) -> f64 {
    match points.iter().position(|p| p.0 >= t) {
        None => points.last().map_or(0.0, |p| p.1),
        Some(0) => points[0].1,
        Some(k) => {
            let ((t0, v0), (t1, v1)) = (points[k - 1], points[k]);
            v0 + (v1 - v0) * (t - t0) / (t1 - t0)
        }
    }
}

/// Integrates the run. The step is a hundredth of the finest output interval (and at most
/// 1e-5 s), so the fold oscillations are resolved.
pub fn simulate(m: &Model) -> History {
    let th = Theory::new(m);
    let finest = [m.run.dt_rcforc, m.run.dt_glstat, m.run.dt_nodout]
        .into_iter()
        .flatten()
        .fold(m.run.end_time, f64::min);
    let dt = (finest / 100.0).min(1e-5);
    let n = (m.run.end_time / dt).round().max(1.0) as usize;
    let s = &m.striker;
    let mut steps = Vec::with_capacity(n + 1);
    let mut cur = Step {
        speed: s.speed,
        kinetic: 0.5 * s.mass * s.speed * s.speed,
        ..Step::default()
    };
    let mut max_crush = 0.0f64;
    let mut max_force = 0.0f64;
    for k in 0..=n {
        cur.time = k as f64 * dt;
        let loading = th.loading_force(m, cur.crush.max(max_crush), cur.speed.max(0.0));
        if cur.crush >= max_crush {
            max_crush = cur.crush;
            max_force = loading;
        }
        cur.force = (max_force - th.stiffness * (max_crush - cur.crush)).max(0.0);
        steps.push(cur);
        cur = advance(m, &cur, dt, cur.force);
    }
    History { theory: th, dt, steps }
}

/// One step: prescribed speed, or free flight decelerated by the force.
fn advance(m: &Model, s: &Step, dt: f64, force: f64) -> Step {
    let t1 = s.time + dt;
    let (speed, accel) = match &m.striker.prescribed {
        Some(curve) => {
            let v1 = curve_at(curve, t1);
            (v1, (v1 - s.speed) / dt)
        }
        None => {
            let a = -force / m.striker.mass;
            (s.speed + a * dt, a)
        }
    };
    let dd = 0.5 * (s.speed + speed) * dt;
    let work = force * dd;
    let kinetic = 0.5 * m.striker.mass * speed * speed;
    let external = match m.striker.prescribed {
        Some(_) => s.external + work + (kinetic - s.kinetic),
        None => s.external,
    };
    Step {
        time: t1,
        crush: s.crush + dd,
        speed,
        accel,
        force,
        internal: s.internal + work,
        external,
        kinetic,
    }
}
