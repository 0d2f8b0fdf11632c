//! Structure manipulations ([references: frasson §3.7.1]): insert, delete, freeze, move and resize/rotate
//! generators, then re-run Lloyd from the current state (frozen generators do not move).
//!
//! * `Insert`: the new generator gets the next id (`len`). Its centre must be allowed.
//! * `Delete` by id, or `DeleteAt` a point: the generator with the smallest elliptic distance
//!   to the point (the one whose region most likely contains it; ties: lowest id). Later ids
//!   shift down by one.
//! * `Freeze` / unfreeze.
//! * `Move`: the thesis's "delete + insert" with unchanged size; done in place, so the id is
//!   kept (only ids, i.e. flooding tie-breaks, differ from a literal delete + insert).
//! * `Set`: new `a`, `b` and/or `θ` (canonicalised so `a ≥ b`, `θ ∈ [0, π)`).
//!
//! Stage 2 must be re-run on the new mesh afterwards (not done here).

use serde::{Deserialize, Serialize};

use crate::synth::structure::relaxation::controls::{point_allowed, Controls};
use crate::synth::structure::relaxation::lloyd::{lloyd, LloydParams, LloydResult};
use crate::synth::structure::relaxation::metric::{canonical, elliptic_distance};
use crate::synth::structure::types::{Ellipse, Point};

/// An editable generator list.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Generators {
    pub ellipses: Vec<Ellipse>,
    pub frozen: Vec<bool>,
}

impl Generators {
    pub fn new(ellipses: Vec<Ellipse>) -> Self {
        let frozen = vec![false; ellipses.len()];
        Generators { ellipses, frozen }
    }

    pub fn len(&self) -> usize {
        self.ellipses.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ellipses.is_empty()
    }

    /// The generators after a Lloyd run (orphans dropped, frozen flags carried over).
    pub fn from_lloyd(r: &LloydResult) -> Self {
        Generators { ellipses: r.generators.clone(), frozen: r.frozen.clone() }
    }

    /// The generator nearest to `p` under the elliptic metric (ties: lowest id).
    pub fn nearest(&self, p: Point) -> Option<usize> {
        let mut best: Option<(f64, usize)> = None;
        for (i, e) in self.ellipses.iter().enumerate() {
            let d = elliptic_distance(e, p);
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, i));
            }
        }
        best.map(|b| b.1)
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum Edit {
    Insert { ellipse: Ellipse, frozen: bool },
    Delete { id: usize },
    DeleteAt { point: Point },
    Freeze { id: usize, frozen: bool },
    Move { id: usize, to: Point },
    Set { id: usize, a: Option<f64>, b: Option<f64>, theta: Option<f64> },
}

#[derive(Clone, Debug, PartialEq)]
pub enum EditError {
    NoSuchGenerator(usize),
    /// `DeleteAt` on an empty list.
    Empty,
    /// The new centre lies outside the target (`width × height`).
    Outside {
        point: Point,
        width: usize,
        height: usize,
    },
    /// The new centre lies in a pixel the occupancy map forbids.
    Forbidden(Point),
    /// Non-positive or non-finite axes / angle.
    InvalidShape,
}

impl std::fmt::Display for EditError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EditError::NoSuchGenerator(i) => write!(f, "no generator with id {i}"),
            EditError::Empty => write!(f, "no generator to delete"),
            EditError::Outside { point: p, width, height } => {
                write!(f, "position ({}, {}) lies outside the {width} x {height} target", p[0], p[1])
            }
            EditError::Forbidden(p) => {
                write!(f, "position ({}, {}) lies where the occupancy map forbids regions", p[0], p[1])
            }
            EditError::InvalidShape => write!(f, "axes must be positive and finite"),
        }
    }
}

impl std::error::Error for EditError {}

/// Where edits may place centres: the target size and its optional allowed mask.
#[derive(Clone, Copy, Debug)]
pub struct Target<'a> {
    pub width: usize,
    pub height: usize,
    pub allowed: Option<&'a [bool]>,
}

/// Applies one edit; returns the id it concerns (inserted, deleted, moved, …).
pub fn apply_edit(g: &mut Generators, edit: &Edit, target: &Target) -> Result<usize, EditError> {
    let check_id = |id: usize, g: &Generators| if id < g.len() { Ok(id) } else { Err(EditError::NoSuchGenerator(id)) };
    let check_pos = |p: Point| {
        // Outside the raster is a wrong position whether or not there is an occupancy map.
        if !point_allowed(None, target.width, target.height, p) {
            Err(EditError::Outside { point: p, width: target.width, height: target.height })
        } else if point_allowed(target.allowed, target.width, target.height, p) {
            Ok(())
        } else {
            Err(EditError::Forbidden(p))
        }
    };
    match edit {
        Edit::Insert { ellipse, frozen } => {
            let e = valid_shape(*ellipse)?;
            check_pos(e.center)?;
            g.ellipses.push(e);
            g.frozen.push(*frozen);
            Ok(g.len() - 1)
        }
        Edit::Delete { id } => {
            let id = check_id(*id, g)?;
            g.ellipses.remove(id);
            g.frozen.remove(id);
            Ok(id)
        }
        Edit::DeleteAt { point } => {
            let id = g.nearest(*point).ok_or(EditError::Empty)?;
            g.ellipses.remove(id);
            g.frozen.remove(id);
            Ok(id)
        }
        Edit::Freeze { id, frozen } => {
            let id = check_id(*id, g)?;
            g.frozen[id] = *frozen;
            Ok(id)
        }
        Edit::Move { id, to } => {
            let id = check_id(*id, g)?;
            check_pos(*to)?;
            g.ellipses[id].center = *to;
            Ok(id)
        }
        Edit::Set { id, a, b, theta } => {
            let id = check_id(*id, g)?;
            let mut e = g.ellipses[id];
            if let Some(a) = a {
                e.a = *a;
            }
            if let Some(b) = b {
                e.b = *b;
            }
            if let Some(t) = theta {
                e.theta = *t;
            }
            g.ellipses[id] = valid_shape(e)?;
            Ok(id)
        }
    }
}

fn valid_shape(e: Ellipse) -> Result<Ellipse, EditError> {
    let ok = e.a.is_finite() && e.b.is_finite() && e.a > 0.0 && e.b > 0.0 && e.theta.is_finite();
    if ok {
        Ok(canonical(e))
    } else {
        Err(EditError::InvalidShape)
    }
}

/// Applies `edits` in order (all or nothing).
pub fn apply_edits(g: &Generators, edits: &[Edit], target: &Target) -> Result<Generators, EditError> {
    let mut out = g.clone();
    for e in edits {
        apply_edit(&mut out, e, target)?;
    }
    Ok(out)
}

/// Applies `edits`, then re-runs Lloyd from the edited state with the same controls.
pub fn edit_and_relax(
    width: usize,
    height: usize,
    g: &Generators,
    edits: &[Edit],
    controls: &Controls,
    params: &LloydParams,
) -> Result<(Generators, LloydResult), EditError> {
    let allowed = controls.allowed();
    let target = Target { width, height, allowed: allowed.as_deref() };
    let edited = apply_edits(g, edits, &target)?;
    let r = lloyd(width, height, &edited.ellipses, Some(&edited.frozen), controls, params);
    Ok((Generators::from_lloyd(&r), r))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::Rng;
    use crate::synth::structure::fixtures::ellipses::random_ellipses;
    use crate::synth::structure::relaxation::voronoi::region_sizes;

    const W: usize = 400;
    const H: usize = 400;

    /// A well-converged starting state.
    fn base() -> (Generators, LloydParams) {
        let mut rng = Rng::new(170);
        let gens = random_ellipses(&mut rng, 160, W, H, 10.0, 22.0, 2.0);
        let params = LloydParams { tol: 0.05, max_iters: 300, ..Default::default() };
        let r = lloyd(W, H, &gens, None, &Controls::default(), &params);
        assert!(r.converged);
        eprintln!("F17 base: {} iterations", r.iterations.len());
        (Generators::from_lloyd(&r), params)
    }

    fn mean_area(r: &LloydResult) -> (usize, f64) {
        let sizes = region_sizes(&r.labels, r.generators.len());
        let nonempty: Vec<usize> = sizes.into_iter().filter(|&s| s > 0).collect();
        (nonempty.len(), nonempty.iter().sum::<usize>() as f64 / nonempty.len() as f64)
    }

    /// F17: delete → N−1 and mean area × N/(N−1); insert → N+1; locality; frozen; move.
    #[test]
    fn f17_edits() {
        let (g, params) = base();
        let n = g.len();
        let before = lloyd(W, H, &g.ellipses, None, &Controls::default(), &LloydParams { max_iters: 0, ..params });
        let (n0, a0) = mean_area(&before);
        assert_eq!(n0, n);

        // Delete (by point).
        let (gd, rd) =
            edit_and_relax(W, H, &g, &[Edit::DeleteAt { point: [200.0, 200.0] }], &Controls::default(), &params)
                .unwrap();
        let (nd, ad) = mean_area(&rd);
        let growth = ad / a0 / (n as f64 / (n - 1) as f64);
        eprintln!(
            "F17 delete: {n} -> {nd} regions, mean area ×{:.4} (expected ×{:.4})",
            ad / a0,
            n as f64 / (n - 1) as f64
        );
        assert_eq!(gd.len(), n - 1);
        assert_eq!(nd, n - 1);
        assert!((growth - 1.0).abs() <= 0.03);

        // Insert, with locality of the response.
        let p = [133.0, 251.0];
        let ins = Ellipse { center: p, a: 16.0, b: 11.0, theta: 0.4 };
        let (gi, ri) =
            edit_and_relax(W, H, &g, &[Edit::Insert { ellipse: ins, frozen: false }], &Controls::default(), &params)
                .unwrap();
        let (ni, ai) = mean_area(&ri);
        eprintln!(
            "F17 insert: {n} -> {ni} regions, mean area ×{:.4} (expected ×{:.4})",
            ai / a0,
            n as f64 / (n + 1) as f64
        );
        assert_eq!(ni, n + 1);
        assert!((ai / a0 / (n as f64 / (n + 1) as f64) - 1.0).abs() <= 0.03);
        let mut moves: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let (a, b) = (g.ellipses[i].center, gi.ellipses[i].center);
                ((a[0] - p[0]).hypot(a[1] - p[1]), (a[0] - b[0]).hypot(a[1] - b[1]))
            })
            .collect();
        moves.sort_by(|x, y| x.0.total_cmp(&y.0));
        let q = n / 4;
        let near = moves[..q].iter().map(|m| m.1).sum::<f64>() / q as f64;
        let far = moves[n - q..].iter().map(|m| m.1).sum::<f64>() / q as f64;
        eprintln!(
            "F17 locality: near-quartile mean displacement {near:.3}, far {far:.3}, ratio {:.1}",
            near / far.max(1e-12)
        );
        assert!(near > 3.0 * far);

        // Frozen: freeze the generator nearest to the insertion point, insert again.
        let k = g.nearest([140.0, 240.0]).unwrap();
        let (gf, _) = edit_and_relax(
            W,
            H,
            &g,
            &[Edit::Freeze { id: k, frozen: true }, Edit::Insert { ellipse: ins, frozen: false }],
            &Controls::default(),
            &params,
        )
        .unwrap();
        let disp = (gf.ellipses[k].center[0] - g.ellipses[k].center[0])
            .hypot(gf.ellipses[k].center[1] - g.ellipses[k].center[1]);
        eprintln!("F17 frozen: displacement {disp}");
        assert_eq!(disp, 0.0);
        assert_eq!(gf.ellipses[k], g.ellipses[k]);
        assert!(gf.frozen[k]);

        // Move: the (a, b) multiset is unchanged.
        let (gm, rm) =
            edit_and_relax(W, H, &g, &[Edit::Move { id: 7, to: [300.0, 80.0] }], &Controls::default(), &params)
                .unwrap();
        let key = |v: &[Ellipse]| {
            let mut k: Vec<(u64, u64)> = v.iter().map(|e| (e.a.to_bits(), e.b.to_bits())).collect();
            k.sort_unstable();
            k
        };
        assert_eq!(key(&g.ellipses), key(&gm.ellipses));
        assert_eq!(mean_area(&rm).0, n);
    }

    #[test]
    fn set_and_errors() {
        let mut g = Generators::new(vec![Ellipse { center: [10.0, 10.0], a: 5.0, b: 3.0, theta: 0.0 }]);
        let allowed: Vec<bool> = (0..100).map(|i| i % 10 < 5).collect();
        let t = Target { width: 10, height: 10, allowed: Some(&allowed) };
        apply_edit(&mut g, &Edit::Set { id: 0, a: Some(2.0), b: None, theta: Some(0.5) }, &t).unwrap();
        let e = g.ellipses[0];
        assert_eq!((e.a, e.b), (3.0, 2.0));
        assert!((e.theta - (0.5 + std::f64::consts::FRAC_PI_2)).abs() < 1e-12);
        assert_eq!(apply_edit(&mut g, &Edit::Delete { id: 3 }, &t), Err(EditError::NoSuchGenerator(3)));
        assert_eq!(
            apply_edit(&mut g, &Edit::Move { id: 0, to: [7.5, 1.0] }, &t),
            Err(EditError::Forbidden([7.5, 1.0]))
        );
        assert_eq!(
            apply_edit(&mut g, &Edit::Move { id: 0, to: [12.0, 1.0] }, &t),
            Err(EditError::Outside { point: [12.0, 1.0], width: 10, height: 10 })
        );
        assert_eq!(
            apply_edit(&mut g, &Edit::Set { id: 0, a: Some(-1.0), b: None, theta: None }, &t),
            Err(EditError::InvalidShape)
        );
        let ins = Edit::Insert { ellipse: Ellipse { center: [2.5, 2.5], a: 1.0, b: 1.0, theta: 0.0 }, frozen: true };
        assert_eq!(apply_edit(&mut g, &ins, &t), Ok(1));
        assert_eq!(g.frozen, vec![false, true]);
        assert_eq!(apply_edit(&mut g, &Edit::DeleteAt { point: [2.0, 2.0] }, &t), Ok(1));
        assert_eq!(g.len(), 1);
        let json = serde_json::to_string(&Edit::Freeze { id: 0, frozen: true }).unwrap();
        assert_eq!(json, r#"{"op":"freeze","id":0,"frozen":true}"#);
    }
}
