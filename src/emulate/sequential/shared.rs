//! One emulator across the designs: η(d, x) over the tested designs' coordinates d and the box,
//! fitted to every design's runs (the η(x, θ) of Kennedy & O'Hagan 2001, §2.1), where the
//! per-design emulators of the parent module each see their own design's runs only.
//!
//! Where the response is smooth across the designs, a run at one design tells the emulator about
//! its neighbours: the variance a run at (d′, x*) removes at (d, x) is c((d, x), (d′, x*))² /
//! c((d′, x*), (d′, x*)), non-zero between designs, so the batch is chosen over every open
//! design's candidates at once by the same integrated-variance value (step 3 of the parent
//! module), summed over the open designs' posterior points. Where the response is not smooth
//! across the designs, the emulator's maximum-likelihood roughness in d says so and the designs
//! stop informing one another: the runs go back to every design, as with the per-design emulators.

use super::*;

/// The joint space's bounds: the designs' coordinates' range, then the box.
pub fn joint_bounds(designs: &[Vec<f64>], bounds: &Bounds) -> Bounds {
    let d = designs.first().map_or(0, Vec::len);
    let lo = (0..d).map(|j| designs.iter().map(|v| v[j]).fold(f64::INFINITY, f64::min));
    let hi = (0..d).map(|j| designs.iter().map(|v| v[j]).fold(f64::NEG_INFINITY, f64::max));
    Bounds::new(
        lo.chain(bounds.lower.iter().copied()).collect(),
        hi.chain(bounds.upper.iter().copied()).collect(),
    )
}

/// Every output's emulator over (design, x), fitted to every site's runs (`designs[s]` is site s's
/// coordinates); each site gets it with its design's coordinates. `None` for an output where the
/// runs in all are too few, or the fit failed.
pub fn emulators(designs: &[Vec<f64>], bounds: &Bounds, sites: &[Site]) -> Vec<SiteEmulators> {
    let joint = joint_bounds(designs, bounds);
    let outputs = sites.first().map_or(0, |s| s.observed.len());
    let shared: Vec<Option<Emulator>> = (0..outputs)
        .map(|k| {
            let runs: Vec<crate::emulate::Run<f64>> =
                sites.iter().zip(designs).flat_map(|(s, d)| s.runs(k, d)).collect();
            <Emulator as crate::emulate::Emulator>::fit(&joint, &runs).ok()
        })
        .collect();
    designs
        .iter()
        .map(|d| SiteEmulators {
            outputs: shared.clone(),
            at: d.clone(),
        })
        .collect()
}

/// One candidate of the joint gain: its site and point.
struct Candidate {
    site: usize,
    snapped: Vec<f64>,
}

/// The next `q` runs among the `open` sites, chosen over all of them at once (module notes); a
/// site that the shared emulator cannot yet be fitted for gets a space-filling run first.
pub(super) fn choose(
    bounds: &Bounds,
    sites: &[Site],
    emus: &[SiteEmulators],
    posterior: &Posterior,
    open: &[bool],
    q: usize,
    seed: u64,
) -> Vec<(usize, Vec<f64>)> {
    let (scaled, points) = candidates(bounds, posterior, seed);
    let opened: Vec<usize> = (0..sites.len()).filter(|&s| open[s]).collect();
    let Some(mut gain) = joint_gain(sites, emus, posterior, &opened, &points) else {
        return opened
            .iter()
            .take(q)
            .map(|&s| (s, snap(bounds, &farthest(&scaled, &sites[s].x, bounds))))
            .collect();
    };
    let candidates: Vec<Candidate> = opened
        .iter()
        .flat_map(|&site| points.row_iter().map(move |r| (site, r)))
        .map(|(site, r)| Candidate {
            site,
            snapped: snap(bounds, r.transpose().as_slice()),
        })
        .collect();
    for &s in &opened {
        for x in &sites[s].x {
            take(&mut gain, &candidates, s, &snap(bounds, x));
        }
    }
    let mut picks = Vec::new();
    while picks.len() < q {
        let (c, v) = gain.best();
        if v == f64::NEG_INFINITY {
            break;
        }
        let pick = &candidates[c];
        picks.push((pick.site, pick.snapped.clone()));
        gain.condition(c);
        let (site, x) = (pick.site, pick.snapped.clone());
        take(&mut gain, &candidates, site, &x);
    }
    picks
}

/// Marks the candidates of `site` at `x` as taken: a run there would repeat one.
fn take(gain: &mut Gain, candidates: &[Candidate], site: usize, x: &[f64]) {
    for (t, c) in gain.taken.iter_mut().zip(candidates) {
        *t |= c.site == site && c.snapped.as_slice() == x;
    }
}

/// The gain over the `points` at every site of `opened` (rows: site by site, the points in order;
/// the posterior's points first, weighted), with each output's covariance between sites scaled by
/// 1/τ of each row's site. `None` where an output has no shared emulator.
fn joint_gain(
    sites: &[Site],
    emus: &[SiteEmulators],
    posterior: &Posterior,
    opened: &[usize],
    points: &DMatrix<f64>,
) -> Option<Gain> {
    let m = points.nrows();
    let rows: Vec<DMatrix<f64>> = opened.iter().map(|&s| emus[s].rows(points)).collect();
    let joint = DMatrix::from_fn(m * opened.len(), rows.first()?.ncols(), |i, j| rows[i / m][(i % m, j)]);
    let outputs = emus.first()?.outputs.len();
    let cov: Option<Vec<DMatrix<f64>>> = (0..outputs)
        .map(|k| {
            let (_, c) = emus.first()?.outputs[k].as_ref()?.mean_cov(&joint)?;
            let tau: Vec<f64> = (0..joint.nrows())
                .map(|i| sites[opened[i / m]].noise[k].sqrt())
                .collect();
            Some(DMatrix::from_fn(c.nrows(), c.ncols(), |a, b| {
                c[(a, b)] / (tau[a] * tau[b])
            }))
        })
        .collect();
    let weights = (0..joint.nrows())
        .map(|i| posterior.weights.get(i % m).copied().unwrap_or(0.0))
        .collect();
    Some(Gain::new(cov?, weights))
}

#[cfg(test)]
mod tests;
