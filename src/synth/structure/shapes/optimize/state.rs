//! The mutable state of the iterations: vertex positions, region cycles, incidence and each
//! vertex's freedom, with the moves validated against the guard.

use super::moves::{constrained, freedom, star_valid, Freedom};
use super::params::ShapeParams;
use crate::synth::structure::types::{Mesh, Point};

/// The distinct edges of the cycles, sorted.
pub(super) fn mesh_edges(regions: &[Vec<usize>]) -> Vec<[usize; 2]> {
    let mut e: Vec<[usize; 2]> = Vec::new();
    for c in regions {
        for k in 0..c.len() {
            let (a, b) = (c[k], c[(k + 1) % c.len()]);
            if a != b {
                e.push([a.min(b), a.max(b)]);
            }
        }
    }
    e.sort_unstable();
    e.dedup();
    e
}

/// Mutable optimisation state.
#[derive(Clone)]
pub(super) struct State<'a> {
    pub(super) verts: Vec<Point>,
    pub(super) regions: Vec<Vec<usize>>,
    /// Per vertex: the regions containing it and the vertex's position in each cycle.
    pub(super) incidence: Vec<Vec<(usize, usize)>>,
    pub(super) freedom: Vec<Freedom>,
    pub(super) domain: [f64; 2],
    pub(super) eps: f64,
    pub(super) params: &'a ShapeParams,
    pub(super) rejected: usize,
    pub(super) halved: usize,
}

impl<'a> State<'a> {
    pub(super) fn new(
        mesh: &Mesh,
        fixed: &[bool],
        border: &[bool],
        domain: [f64; 2],
        params: &'a ShapeParams,
    ) -> State<'a> {
        let nv = mesh.vertices.len();
        let eps = 1e-9 * (domain[0].abs() + domain[1].abs()).max(1.0);
        let freedom: Vec<Freedom> =
            (0..nv).map(|v| freedom(mesh.vertices[v], fixed[v], border[v], domain, eps)).collect();
        let mut incidence: Vec<Vec<(usize, usize)>> = vec![Vec::new(); nv];
        for (r, c) in mesh.regions.iter().enumerate() {
            for (k, &v) in c.iter().enumerate() {
                incidence[v].push((r, k));
            }
        }
        State {
            verts: mesh.vertices.clone(),
            regions: mesh.regions.clone(),
            incidence,
            freedom,
            domain,
            eps,
            params,
            rejected: 0,
            halved: 0,
        }
    }

    /// Tries to move `v` by `d` (constrained), halving up to `max_halvings` times.
    pub(super) fn try_move(&mut self, v: usize, d: Point) {
        if d[0] == 0.0 && d[1] == 0.0 {
            return;
        }
        let f = self.freedom[v];
        let p = self.verts[v];
        let mut scale = 1.0;
        for attempt in 0..=self.params.max_halvings {
            let Some(q) = constrained(p, [d[0] * scale, d[1] * scale], f, self.domain) else {
                return;
            };
            if q == p {
                return;
            }
            if self.valid_at(v, q) {
                self.verts[v] = q;
                if attempt > 0 {
                    self.halved += 1;
                }
                return;
            }
            scale *= 0.5;
        }
        self.rejected += 1;
    }

    pub(super) fn valid_at(&self, v: usize, q: Point) -> bool {
        let e = self.eps;
        if !(q[0] >= -e && q[1] >= -e && q[0] <= self.domain[0] + e && q[1] <= self.domain[1] + e) {
            return false;
        }
        let verts = &self.verts;
        let pos = |i: usize| if i == v { q } else { verts[i] };
        let cycles: Vec<&[usize]> = self.incidence[v].iter().map(|&(r, _)| self.regions[r].as_slice()).collect();
        star_valid(&pos, &cycles, v, e)
    }
}
