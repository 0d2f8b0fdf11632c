//! Seeded synthetic stand-ins for the thesis's structure samples ([references: frasson §3.6]), with their
//! ground truth: the exact polygon mesh, its subdivision, and per-region classes.
//!
//! | generator | thesis example | construction |
//! |---|---|---|
//! | [`wall_random`] | INRIA wall | Poisson-disk sites in two size classes (30 % radius `r`, 70 % `2.5r`), power diagram, edges bent by ±2 px |
//! | [`wall_layered`] | Levens wall | courses of 40–70 px, stones of aspect 1.5–3 with tilted joints, density map with dark bands on the course centre lines |
//! | [`wall_regular`] | Valbonne wall | brick courses of near-rectangular blocks, some small upright blocks (correlated `a, b, θ`), stripe density map |
//! | [`cells_iso`] | meristem | Euclidean CVD of random points (Lloyd on clipped Voronoi cells), 5 % of cells cut into a triangle and the rest |
//! | [`scales_diag`] | snake skin | elongated hexagons of a lattice rotated by 30°, small triangles at some lattice nodes, 400×270 |
//!
//! Every generator is a pure function of its parameters and seed (streams derived with
//! [`Rng::derived`]); the meshes tile `[0, w] × [0, h]` exactly, regions have positive signed
//! area (see [`Mesh`]), and the subdivisions pass [`super::validate::clean`] with nothing to
//! remove. Sizes are modest by default and every size and count is a parameter.
//!
//! Density maps are luminance images (`w × h`, row-major, `0` = dark = dense), as a user
//! would draw them. Occupancy masks are `1` where synthesis is allowed and `0` in openings.

use super::ellipse::polygon_moments;
use super::faces::{mesh_to_subdivision, signed_area};
use super::labels_import::rasterize_polygons;
use super::types::{Labels, Mesh, Point, Subdivision};
use super::validate;
use crate::synth::rng::Rng;
use std::collections::HashMap;
use std::f64::consts::PI;

/// A synthetic structure sample and its ground truth.
#[derive(Clone, Debug, PartialEq)]
pub struct StandIn {
    pub name: &'static str,
    pub width: usize,
    pub height: usize,
    pub mesh: Mesh,
    /// `mesh_to_subdivision(&mesh)`.
    pub subdivision: Subdivision,
    /// Appearance (tint) class per region.
    pub classes: Vec<u32>,
    /// Shape group per region; the meaning is documented on each generator.
    pub groups: Vec<u32>,
    /// Optional hand-drawn-style density map (luminance, dark = dense).
    pub density: Option<Vec<f32>>,
}

impl StandIn {
    /// Region boundary polygons.
    pub fn polygons(&self) -> Vec<Vec<Point>> {
        self.mesh.regions.iter().map(|c| c.iter().map(|&i| self.mesh.vertices[i]).collect()).collect()
    }

    /// Ground-truth label raster (region index per pixel centre).
    pub fn rasterize(&self) -> Labels {
        rasterize_polygons(&self.polygons(), self.width, self.height)
    }

    /// Regions with a vertex on the sample border.
    pub fn border_regions(&self) -> Vec<bool> {
        let (w, h) = (self.width as f64, self.height as f64);
        let eps = 1e-6;
        self.mesh
            .regions
            .iter()
            .map(|c| {
                c.iter().any(|&i| {
                    let p = self.mesh.vertices[i];
                    p[0] <= eps || p[1] <= eps || p[0] >= w - eps || p[1] >= h - eps
                })
            })
            .collect()
    }
}

// ---------------------------------------------------------------------------------------
// Geometry helpers: power diagrams by half-plane clipping, welding, mesh edits.

/// Keeps the part of a convex polygon with `n · (x − o) ≤ c`.
fn clip(poly: &[Point], o: Point, n: Point, c: f64) -> Vec<Point> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    let m = poly.len();
    for i in 0..m {
        let (p, q) = (poly[i], poly[(i + 1) % m]);
        let dp = n[0] * (p[0] - o[0]) + n[1] * (p[1] - o[1]) - c;
        let dq = n[0] * (q[0] - o[0]) + n[1] * (q[1] - o[1]) - c;
        if dp <= 0.0 {
            out.push(p);
        }
        if (dp <= 0.0) != (dq <= 0.0) {
            let t = dp / (dp - dq);
            out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
        }
    }
    out
}

/// Power-diagram cells of weighted sites clipped to `[0, w] × [0, h]` (`weights = 0`:
/// Voronoi). Cells are convex with positive signed area; empty cells are empty vectors.
pub fn power_cells(sites: &[Point], weights: &[f64], w: f64, h: f64) -> Vec<Vec<Point>> {
    (0..sites.len())
        .map(|i| {
            let p = sites[i];
            let mut poly = vec![[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]];
            // Nearest sites first: the cell shrinks fast and later clips are cheap no-ops.
            let mut order: Vec<usize> = (0..sites.len()).filter(|&j| j != i).collect();
            let d2 = |j: usize| (sites[j][0] - p[0]).powi(2) + (sites[j][1] - p[1]).powi(2);
            order.sort_by(|&a, &b| d2(a).total_cmp(&d2(b)).then(a.cmp(&b)));
            for j in order {
                if poly.is_empty() {
                    break;
                }
                let d = [sites[j][0] - p[0], sites[j][1] - p[1]];
                let dd = d[0] * d[0] + d[1] * d[1];
                let c = 0.5 * (dd - weights[j] + weights[i]);
                // Skip bisectors beyond the cell's farthest vertex.
                let reach = poly.iter().map(|v| d[0] * (v[0] - p[0]) + d[1] * (v[1] - p[1])).fold(f64::MIN, f64::max);
                if reach <= c {
                    continue;
                }
                poly = clip(&poly, p, d, c);
            }
            if poly.len() < 3 || signed_area(&poly) <= 0.0 {
                Vec::new()
            } else {
                poly
            }
        })
        .collect()
}

/// Welds cell polygons into a shared-vertex mesh (vertices closer than `tol` merge; the
/// first occurrence's position is kept). Consecutive duplicates are dropped; cells left with
/// fewer than 3 vertices become empty cycles.
fn weld(cells: &[Vec<Point>], tol: f64) -> Mesh {
    let mut grid: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    let mut vertices: Vec<Point> = Vec::new();
    let key = |p: Point| ((p[0] / tol).floor() as i64, (p[1] / tol).floor() as i64);
    let mut regions = Vec::with_capacity(cells.len());
    for cell in cells {
        let mut cyc: Vec<usize> = Vec::with_capacity(cell.len());
        for &p in cell {
            let k = key(p);
            let mut found = None;
            'search: for dx in -1..=1 {
                for dy in -1..=1 {
                    if let Some(list) = grid.get(&(k.0 + dx, k.1 + dy)) {
                        for &v in list {
                            let q = vertices[v];
                            if (q[0] - p[0]).abs() <= tol && (q[1] - p[1]).abs() <= tol {
                                found = Some(v);
                                break 'search;
                            }
                        }
                    }
                }
            }
            let id = found.unwrap_or_else(|| {
                vertices.push(p);
                grid.entry(k).or_default().push(vertices.len() - 1);
                vertices.len() - 1
            });
            if cyc.last() != Some(&id) {
                cyc.push(id);
            }
        }
        while cyc.len() > 1 && cyc.first() == cyc.last() {
            cyc.pop();
        }
        if cyc.len() < 3 {
            cyc.clear();
        }
        regions.push(cyc);
    }
    Mesh { vertices, regions }
}

/// Drops unused vertices and renumbers.
fn compact(mesh: &Mesh) -> Mesh {
    let mut map = vec![usize::MAX; mesh.vertices.len()];
    let mut vertices = Vec::new();
    let regions = mesh
        .regions
        .iter()
        .map(|c| {
            c.iter()
                .map(|&i| {
                    if map[i] == usize::MAX {
                        map[i] = vertices.len();
                        vertices.push(mesh.vertices[i]);
                    }
                    map[i]
                })
                .collect()
        })
        .collect();
    Mesh { vertices, regions }
}

/// Power diagram of the sites as a mesh, regions in site order. Sites whose cell is
/// smaller than `min_area` are dropped and the diagram recomputed (their neighbours absorb
/// them), so no sliver region survives; returns the mesh and the surviving site indices.
fn power_mesh(sites: &[Point], weights: &[f64], w: f64, h: f64, min_area: f64) -> (Mesh, Vec<usize>) {
    let mut alive: Vec<usize> = (0..sites.len()).collect();
    loop {
        let s: Vec<Point> = alive.iter().map(|&i| sites[i]).collect();
        let wt: Vec<f64> = alive.iter().map(|&i| weights[i]).collect();
        let cells = power_cells(&s, &wt, w, h);
        let small: Vec<bool> = cells.iter().map(|c| c.is_empty() || signed_area(c) < min_area).collect();
        if small.iter().any(|&b| b) {
            alive = alive.iter().zip(&small).filter(|(_, &b)| !b).map(|(&i, _)| i).collect();
            continue;
        }
        let mesh = weld(&cells, 1e-7 * w.max(h));
        if mesh.regions.iter().any(|c| c.is_empty()) {
            // A cell collapsed in welding (not seen in practice): drop it like a sliver.
            let keep: Vec<usize> =
                alive.iter().zip(&mesh.regions).filter(|(_, c)| !c.is_empty()).map(|(&i, _)| i).collect();
            alive = keep;
            continue;
        }
        return (compact(&mesh), alive);
    }
}

/// Bends interior edges: each interior edge at least `min_len` long gets a midpoint moved
/// perpendicular by a uniform offset in `[−amount, amount]`. Bends that would make edges
/// cross are undone (repeatedly, until the subdivision is valid).
fn bend_edges(mesh: &Mesh, amount: f64, min_len: f64, w: f64, h: f64, rng: &mut Rng) -> Mesh {
    let sub = mesh_to_subdivision(mesh);
    let on_border = |p: Point| p[0] <= 1e-9 || p[1] <= 1e-9 || p[0] >= w - 1e-9 || p[1] >= h - 1e-9;
    // One offset per edge, drawn in sorted edge order (one draw each, used or not).
    let offsets: Vec<f64> = sub.edges.iter().map(|_| rng.range(-amount, amount)).collect();
    let mut enabled: Vec<bool> = sub
        .edges
        .iter()
        .map(|e| {
            let (a, b) = (sub.vertices[e[0]], sub.vertices[e[1]]);
            let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            len >= min_len && !(on_border(a) && on_border(b))
        })
        .collect();
    let edge_index: HashMap<[usize; 2], usize> = sub.edges.iter().enumerate().map(|(k, &e)| (e, k)).collect();
    loop {
        let mut vertices = mesh.vertices.clone();
        let mut mid = vec![usize::MAX; sub.edges.len()];
        let mut mid_edge = HashMap::new();
        for (k, e) in sub.edges.iter().enumerate() {
            if !enabled[k] {
                continue;
            }
            let (a, b) = (sub.vertices[e[0]], sub.vertices[e[1]]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len = (dx * dx + dy * dy).sqrt();
            let (nx, ny) = (-dy / len, dx / len);
            vertices.push([(a[0] + b[0]) / 2.0 + nx * offsets[k], (a[1] + b[1]) / 2.0 + ny * offsets[k]]);
            mid[k] = vertices.len() - 1;
            mid_edge.insert(mid[k], k);
        }
        let regions: Vec<Vec<usize>> = mesh
            .regions
            .iter()
            .map(|c| {
                let mut out = Vec::with_capacity(c.len() * 2);
                for i in 0..c.len() {
                    let (a, b) = (c[i], c[(i + 1) % c.len()]);
                    out.push(a);
                    let k = edge_index[&[a.min(b), a.max(b)]];
                    if mid[k] != usize::MAX {
                        out.push(mid[k]);
                    }
                }
                out
            })
            .collect();
        let bent = Mesh { vertices, regions };
        let bsub = mesh_to_subdivision(&bent);
        let crossings = validate::find_crossings(&bsub);
        let flipped: Vec<usize> = bent
            .regions
            .iter()
            .enumerate()
            .filter(|(_, c)| signed_area(&c.iter().map(|&i| bent.vertices[i]).collect::<Vec<_>>()) <= 0.0)
            .map(|(r, _)| r)
            .collect();
        if crossings.is_empty() && flipped.is_empty() {
            return bent;
        }
        let mut changed = false;
        for c in &crossings {
            for &e in &c.edges {
                for &v in &bsub.edges[e] {
                    if let Some(&k) = mid_edge.get(&v) {
                        changed |= enabled[k];
                        enabled[k] = false;
                    }
                }
            }
        }
        for &r in &flipped {
            for &v in &bent.regions[r] {
                if let Some(&k) = mid_edge.get(&v) {
                    changed |= enabled[k];
                    enabled[k] = false;
                }
            }
        }
        if !changed {
            // Cannot happen: with every bend undone the mesh is the valid input.
            enabled.iter_mut().for_each(|e| *e = false);
        }
    }
}

fn finish(
    name: &'static str,
    width: usize,
    height: usize,
    mesh: Mesh,
    classes: Vec<u32>,
    groups: Vec<u32>,
    density: Option<Vec<f32>>,
) -> StandIn {
    let subdivision = mesh_to_subdivision(&mesh);
    StandIn { name, width, height, mesh, subdivision, classes, groups, density }
}

// ---------------------------------------------------------------------------------------
// wall_random

/// Parameters of [`wall_random`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallRandomParams {
    pub width: usize,
    pub height: usize,
    /// Number of regions (exact).
    pub count: usize,
    /// Share of small stones.
    pub small_fraction: f64,
    /// Large-stone radius over small-stone radius.
    pub large_ratio: f64,
    /// Largest perpendicular bend of an edge, px.
    pub jitter: f64,
    /// Number of tint classes.
    pub tints: u32,
}

impl Default for WallRandomParams {
    fn default() -> Self {
        WallRandomParams {
            width: 512,
            height: 384,
            count: 100,
            small_fraction: 0.3,
            large_ratio: 2.5,
            jitter: 2.0,
            tints: 3,
        }
    }
}

/// INRIA-wall stand-in: random placement, bimodal sizes. `groups`: 0 = small stone,
/// 1 = large stone. `classes`: tint in `0..tints`. Exactly `count` regions, of which
/// `round(small_fraction · count)` small (placed after the large ones, in the gaps).
pub fn wall_random(params: &WallRandomParams, seed: u64) -> StandIn {
    let (w, h) = (params.width as f64, params.height as f64);
    let n = params.count.max(1);
    let mut rng = Rng::derived(seed, "wall_random", "sites");
    let f = params.small_fraction;
    let k = params.large_ratio;
    // Disks of radius r_i cover about 55 % of the area.
    let mut r = (0.55 * w * h / (n as f64 * PI * (f + (1.0 - f) * k * k))).sqrt();
    let mut sites: Vec<Point> = Vec::with_capacity(n);
    let mut radii: Vec<f64> = Vec::with_capacity(n);
    let mut groups = Vec::with_capacity(n);
    // Large stones first, then small ones filling the gaps (so both counts are exact).
    let n_small = ((f * n as f64).round() as usize).min(n);
    let mut failures = 0usize;
    while sites.len() < n {
        let small = sites.len() >= n - n_small;
        let ri = if small { r } else { k * r };
        let margin = (0.5 * ri).min(0.25 * w.min(h));
        let p = [rng.range(margin, w - margin), rng.range(margin, h - margin)];
        // Spacing 0.9 (r_i + r_j) keeps every site inside its own power cell.
        let ok = sites.iter().zip(&radii).all(|(q, &rj)| {
            let d2 = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
            d2 >= (0.9 * (ri + rj)).powi(2)
        });
        if ok {
            sites.push(p);
            radii.push(ri);
            groups.push(u32::from(!small));
            failures = 0;
        } else {
            failures += 1;
            if failures > 2000 {
                r *= 0.97;
                failures = 0;
            }
        }
    }
    let weights: Vec<f64> = radii.iter().map(|r| r * r).collect();
    let (mesh, alive) = power_mesh(&sites, &weights, w, h, 0.0);
    let groups: Vec<u32> = alive.iter().map(|&i| groups[i]).collect();
    let mut jr = Rng::derived(seed, "wall_random", "jitter");
    let mesh = bend_edges(&mesh, params.jitter, 4.0 * params.jitter, w, h, &mut jr);
    let mut tr = Rng::derived(seed, "wall_random", "tints");
    let classes = (0..mesh.regions.len()).map(|_| tr.below(params.tints.max(1) as usize) as u32).collect();
    finish("wall_random", params.width, params.height, mesh, classes, groups, None)
}

// ---------------------------------------------------------------------------------------
// Coursed walls (wall_layered, wall_regular)

struct CourseSpec {
    /// Course heights (sum = height).
    heights: Vec<f64>,
    /// Slope of each course line (`courses + 1` lines; first and last must be 0).
    slopes: Vec<f64>,
}

/// Builds a wall of courses. `stone` returns (width, joint tilt, group) for the next stone
/// of course `k` with height `ch`. Returns the mesh, the course of each region and its group.
fn coursed_wall(
    w: f64,
    h: f64,
    spec: &CourseSpec,
    rng: &mut Rng,
    mut stone: impl FnMut(&mut Rng, usize, f64) -> (f64, f64, u32),
) -> (Mesh, Vec<u32>, Vec<u32>) {
    let nc = spec.heights.len();
    let mut base = vec![0.0];
    for hk in &spec.heights {
        base.push(base.last().unwrap() + hk);
    }
    let line_y = |k: usize, x: f64| -> f64 {
        if k == 0 {
            0.0
        } else if k == nc {
            h
        } else {
            base[k] + spec.slopes[k] * (x - w / 2.0)
        }
    };
    // Joint end points per course: (x_top, x_bottom, group of the stone left of the joint).
    let mut joints: Vec<Vec<(f64, f64)>> = Vec::with_capacity(nc);
    let mut stone_groups: Vec<Vec<u32>> = Vec::with_capacity(nc);
    let min_gap = 3.0;
    for k in 0..nc {
        let ch = spec.heights[k];
        let mut x = -rng.range(0.0, 1.0) * stone(rng, k, ch).0;
        let mut js = Vec::new();
        let mut gs = Vec::new();
        // A stone that absorbed a skipped joint is wider than drawn: group 0.
        let mut merged = false;
        loop {
            let (sw, tilt, g) = stone(rng, k, ch);
            let group = if merged { 0 } else { g };
            x += sw;
            let off = 0.5 * ch * tilt.tan();
            let (mut xt, mut xb) = (x + off, x - off);
            if xt.max(xb) > w - 0.5 * ch {
                gs.push(group);
                break;
            }
            if xt.min(xb) < 0.5 * ch {
                merged = true;
                continue;
            }
            // Keep joint ends apart from the previous course's joint ends on the shared line.
            if k > 0 {
                for _ in 0..8 {
                    let clash = joints[k - 1].iter().any(|&(_, pb)| (pb - xt).abs() < min_gap);
                    if !clash {
                        break;
                    }
                    xt += min_gap + 1.0;
                    xb += min_gap + 1.0;
                    x += min_gap + 1.0;
                }
            }
            if let Some(&(pt, pb)) = js.last() {
                let (pt, pb): (f64, f64) = (pt, pb);
                if xt - pt < 2.0 * min_gap || xb - pb < 2.0 * min_gap {
                    merged = true;
                    continue;
                }
            }
            if xt.max(xb) > w - 0.5 * ch {
                gs.push(group);
                break;
            }
            js.push((xt, xb));
            gs.push(group);
            merged = false;
        }
        joints.push(js);
        stone_groups.push(gs);
    }
    // Vertices per line, sorted by x.
    let mut vertices: Vec<Point> = Vec::new();
    let mut line_pts: Vec<Vec<(f64, usize)>> = vec![Vec::new(); nc + 1];
    for (k, pts) in line_pts.iter_mut().enumerate() {
        let mut xs = vec![0.0, w];
        if k < nc {
            xs.extend(joints[k].iter().map(|j| j.0));
        }
        if k > 0 {
            xs.extend(joints[k - 1].iter().map(|j| j.1));
        }
        xs.sort_by(f64::total_cmp);
        for x in xs {
            vertices.push([x, line_y(k, x)]);
            pts.push((x, vertices.len() - 1));
        }
    }
    let find = |pts: &Vec<(f64, usize)>, x: f64| pts.iter().position(|p| p.0 == x).expect("joint vertex");
    let mut regions = Vec::new();
    let mut courses = Vec::new();
    let mut groups = Vec::new();
    for k in 0..nc {
        let mut bounds = vec![(0.0, 0.0)];
        bounds.extend(joints[k].iter().copied());
        bounds.push((w, w));
        for s in 0..bounds.len() - 1 {
            let (lt, lb) = bounds[s];
            let (rt, rb) = bounds[s + 1];
            let top = &line_pts[k];
            let bot = &line_pts[k + 1];
            let (i0, i1) = (find(top, lt), find(top, rt));
            let (j0, j1) = (find(bot, lb), find(bot, rb));
            let mut cyc: Vec<usize> = top[i0..=i1].iter().map(|p| p.1).collect();
            cyc.extend(bot[j0..=j1].iter().rev().map(|p| p.1));
            regions.push(cyc);
            courses.push(k as u32);
            groups.push(stone_groups[k].get(s).copied().unwrap_or(0));
        }
    }
    (Mesh { vertices, regions }, courses, groups)
}

/// Luminance density image with dark Gaussian bands (σ = `sigma_frac` × course height) on the
/// course centre lines.
fn band_density(w: usize, h: usize, spec: &CourseSpec, sigma_frac: f64) -> Vec<f32> {
    let nc = spec.heights.len();
    let mut base = vec![0.0];
    for hk in &spec.heights {
        base.push(base.last().unwrap() + hk);
    }
    let line_y = |k: usize, x: f64| -> f64 {
        if k == 0 || k == nc {
            base[k]
        } else {
            base[k] + spec.slopes[k] * (x - w as f64 / 2.0)
        }
    };
    let mut out = vec![1.0f32; w * h];
    for x in 0..w {
        let xc = x as f64 + 0.5;
        for k in 0..nc {
            let (y0, y1) = (line_y(k, xc), line_y(k + 1, xc));
            let (yc, sigma) = ((y0 + y1) / 2.0, sigma_frac * (y1 - y0));
            let lo = (yc - 4.0 * sigma).floor().max(0.0) as usize;
            let hi = ((yc + 4.0 * sigma).ceil() as usize).min(h);
            for y in lo..hi {
                let d = y as f64 + 0.5 - yc;
                let v = 1.0 - (-(d * d) / (2.0 * sigma * sigma)).exp();
                let o = &mut out[y * w + x];
                *o = o.min(v as f32);
            }
        }
    }
    out
}

/// Parameters of [`wall_layered`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallLayeredParams {
    pub width: usize,
    pub height: usize,
    pub courses: usize,
    /// Course height range before scaling to `height`, px.
    pub course_height: [f64; 2],
    /// Stone width / course height range.
    pub aspect: [f64; 2],
    /// Largest joint tilt, degrees.
    pub joint_tilt_deg: f64,
    /// Largest course-line tilt, degrees.
    pub course_tilt_deg: f64,
    /// Number of stones in the "leaf" cluster (class 2).
    pub leaf_stones: usize,
}

impl Default for WallLayeredParams {
    fn default() -> Self {
        WallLayeredParams {
            width: 512,
            height: 448,
            courses: 8,
            course_height: [40.0, 70.0],
            aspect: [1.5, 3.0],
            joint_tilt_deg: 8.0,
            course_tilt_deg: 1.0,
            leaf_stones: 4,
        }
    }
}

/// Levens-wall stand-in: layered courses of elongated stones. `groups`: course index.
/// `classes`: tint 0 or 1, and 2 for a small cluster of "leaf" stones. Density map: dark
/// bands along the course centre lines (σ = course height / 4).
pub fn wall_layered(params: &WallLayeredParams, seed: u64) -> StandIn {
    let (w, h) = (params.width as f64, params.height as f64);
    let mut rng = Rng::derived(seed, "wall_layered", "courses");
    let nc = params.courses.max(1);
    let raw: Vec<f64> = (0..nc).map(|_| rng.range(params.course_height[0], params.course_height[1])).collect();
    let total: f64 = raw.iter().sum();
    let heights: Vec<f64> = raw.iter().map(|v| v * h / total).collect();
    let max_slope = params.course_tilt_deg.to_radians().tan();
    let slopes: Vec<f64> =
        (0..=nc).map(|k| if k == 0 || k == nc { 0.0 } else { rng.range(-max_slope, max_slope) }).collect();
    let spec = CourseSpec { heights, slopes };
    let tilt = params.joint_tilt_deg.to_radians();
    let aspect = params.aspect;
    let mut srng = Rng::derived(seed, "wall_layered", "stones");
    let (mesh, courses, _) =
        coursed_wall(w, h, &spec, &mut srng, |r, _, ch| (r.range(aspect[0], aspect[1]) * ch, r.range(-tilt, tilt), 0));
    let mut tr = Rng::derived(seed, "wall_layered", "tints");
    let mut classes: Vec<u32> = (0..mesh.regions.len()).map(|_| tr.below(2) as u32).collect();
    // Leaf cluster: the stones whose centroids are nearest a random point.
    let c = [tr.range(0.2 * w, 0.8 * w), tr.range(0.2 * h, 0.8 * h)];
    let mut by_dist: Vec<(f64, usize)> = mesh
        .regions
        .iter()
        .enumerate()
        .map(|(r, cyc)| {
            let poly: Vec<Point> = cyc.iter().map(|&i| mesh.vertices[i]).collect();
            let m = polygon_moments(&poly).expect("stone has area");
            ((m.centroid[0] - c[0]).powi(2) + (m.centroid[1] - c[1]).powi(2), r)
        })
        .collect();
    by_dist.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    for &(_, r) in by_dist.iter().take(params.leaf_stones) {
        classes[r] = 2;
    }
    let density = band_density(params.width, params.height, &spec, 0.25);
    finish("wall_layered", params.width, params.height, mesh, classes, courses, Some(density))
}

/// Parameters of [`wall_regular`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallRegularParams {
    pub width: usize,
    pub height: usize,
    pub course_height: f64,
    /// Width range of normal blocks, in course heights.
    pub block_width: [f64; 2],
    /// Width range of upright blocks, in course heights.
    pub upright_width: [f64; 2],
    /// Probability that a block is upright.
    pub upright_fraction: f64,
    /// Largest joint tilt, degrees.
    pub joint_tilt_deg: f64,
}

impl Default for WallRegularParams {
    fn default() -> Self {
        WallRegularParams {
            width: 512,
            height: 384,
            course_height: 32.0,
            block_width: [1.6, 2.6],
            upright_width: [0.45, 0.7],
            upright_fraction: 0.15,
            joint_tilt_deg: 1.5,
        }
    }
}

/// Valbonne-wall stand-in: regular courses of near-rectangular blocks with some small
/// upright blocks (so `a, b, θ` are correlated). `groups`: 0 = normal block, 1 = upright.
/// `classes`: all 0. Density map: stripes dark on the course centre lines (σ = height / 5).
pub fn wall_regular(params: &WallRegularParams, seed: u64) -> StandIn {
    let (w, h) = (params.width as f64, params.height as f64);
    let nc = ((h / params.course_height).round() as usize).max(1);
    let spec = CourseSpec { heights: vec![h / nc as f64; nc], slopes: vec![0.0; nc + 1] };
    let tilt = params.joint_tilt_deg.to_radians();
    let p = *params;
    let mut rng = Rng::derived(seed, "wall_regular", "blocks");
    let (mesh, _, groups) = coursed_wall(w, h, &spec, &mut rng, |r, _, ch| {
        let upright = r.next_f64() < p.upright_fraction;
        let range = if upright { p.upright_width } else { p.block_width };
        (r.range(range[0], range[1]) * ch, r.range(-tilt, tilt), u32::from(upright))
    });
    let classes = vec![0; mesh.regions.len()];
    let density = band_density(params.width, params.height, &spec, 0.2);
    finish("wall_regular", params.width, params.height, mesh, classes, groups, Some(density))
}

// ---------------------------------------------------------------------------------------
// cells_iso

/// Parameters of [`cells_iso`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellsIsoParams {
    pub width: usize,
    pub height: usize,
    /// Number of Voronoi cells.
    pub count: usize,
    pub lloyd_iterations: usize,
    /// Share of cells cut into a triangle and the rest (rounded).
    pub triangle_fraction: f64,
}

impl Default for CellsIsoParams {
    fn default() -> Self {
        CellsIsoParams { width: 384, height: 384, count: 200, lloyd_iterations: 20, triangle_fraction: 0.05 }
    }
}

/// Meristem stand-in: a Euclidean centroidal Voronoi tessellation, with
/// `round(triangle_fraction · count)` cells cut into a triangle (the largest corner triangle)
/// and the rest. Regions: the `count` cells in site order, then the triangles.
/// `groups`: 0 = cell, 1 = triangle. `classes`: all 0.
pub fn cells_iso(params: &CellsIsoParams, seed: u64) -> StandIn {
    let (w, h) = (params.width as f64, params.height as f64);
    let n = params.count.max(1);
    let mut rng = Rng::derived(seed, "cells_iso", "sites");
    let mut sites: Vec<Point> = (0..n).map(|_| [rng.range(0.0, w), rng.range(0.0, h)]).collect();
    let zeros = vec![0.0; n];
    for _ in 0..params.lloyd_iterations {
        let cells = power_cells(&sites, &zeros, w, h);
        for (s, c) in sites.iter_mut().zip(&cells) {
            if let Some(m) = polygon_moments(c) {
                *s = m.centroid;
            }
        }
    }
    let (mut mesh, _alive) = power_mesh(&sites, &zeros, w, h, 0.0);
    let ncells = mesh.regions.len();
    let cuts = ((params.triangle_fraction * n as f64).round() as usize).min(ncells);
    let mut order: Vec<usize> = (0..ncells).collect();
    let mut cr = Rng::derived(seed, "cells_iso", "cuts");
    cr.shuffle(&mut order);
    let mut groups = vec![0u32; ncells];
    let mut done = 0;
    for &r in &order {
        if done == cuts {
            break;
        }
        let cyc = mesh.regions[r].clone();
        let m = cyc.len();
        if m < 4 {
            continue;
        }
        // The corner triangle of largest area.
        let tri_area = |i: usize| {
            let (a, b, c) =
                (mesh.vertices[cyc[(i + m - 1) % m]], mesh.vertices[cyc[i]], mesh.vertices[cyc[(i + 1) % m]]);
            signed_area(&[a, b, c])
        };
        let i = (0..m).max_by(|&a, &b| tri_area(a).total_cmp(&tri_area(b)).then(b.cmp(&a))).expect("non-empty");
        let tri = vec![cyc[(i + m - 1) % m], cyc[i], cyc[(i + 1) % m]];
        let rest: Vec<usize> = (0..m).filter(|&k| k != i).map(|k| cyc[k]).collect();
        mesh.regions[r] = rest;
        mesh.regions.push(tri);
        groups.push(1);
        done += 1;
    }
    let classes = vec![0; mesh.regions.len()];
    finish("cells_iso", params.width, params.height, mesh, classes, groups, None)
}

// ---------------------------------------------------------------------------------------
// scales_diag

/// Parameters of [`scales_diag`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalesDiagParams {
    pub width: usize,
    pub height: usize,
    /// Lattice spacing across the scales (minor direction), px.
    pub spacing: f64,
    /// Spacing along the scales over `spacing` (elongation of the lattice).
    pub elongation: f64,
    /// Lattice rotation, degrees.
    pub angle_deg: f64,
    /// Share of interior lattice nodes replaced by a small triangle.
    pub triangle_fraction: f64,
}

impl Default for ScalesDiagParams {
    fn default() -> Self {
        ScalesDiagParams {
            width: 400,
            height: 270,
            spacing: 24.0,
            elongation: 3.2,
            angle_deg: 30.0,
            triangle_fraction: 0.12,
        }
    }
}

/// Snake-skin stand-in: the Voronoi cells of a centred rectangular lattice (elongated
/// hexagons) rotated by `angle_deg`, with small triangles inserted at some valency-3 nodes.
/// Border cells smaller than a quarter of a full scale are merged into their neighbours.
/// `groups`: 0 = scale, 1 = triangle. `classes`: all 0.
pub fn scales_diag(params: &ScalesDiagParams, seed: u64) -> StandIn {
    let (w, h) = (params.width as f64, params.height as f64);
    let sy = params.spacing;
    let sx = params.spacing * params.elongation;
    let (s, c) = params.angle_deg.to_radians().sin_cos();
    let mut rng = Rng::derived(seed, "scales_diag", "lattice");
    let phase = [rng.range(0.0, sx), rng.range(0.0, sy)];
    let centre = [w / 2.0, h / 2.0];
    let reach = (w * w + h * h).sqrt() / 2.0 + 2.0 * sx;
    let (ni, nj) = ((reach / sx).ceil() as i64 + 1, (reach / sy).ceil() as i64 + 1);
    let mut sites = Vec::new();
    for j in -nj..=nj {
        for i in -ni..=ni {
            for half in [0.0, 0.5] {
                let (u, v) = ((i as f64 + half) * sx + phase[0], (j as f64 + half) * sy + phase[1]);
                let p = [centre[0] + u * c - v * s, centre[1] + u * s + v * c];
                if p[0] > -sx && p[0] < w + sx && p[1] > -sx && p[1] < h + sx {
                    sites.push(p);
                }
            }
        }
    }
    let zeros = vec![0.0; sites.len()];
    let (mut mesh, _) = power_mesh(&sites, &zeros, w, h, 0.25 * sx * sy / 2.0);
    let ncells = mesh.regions.len();
    // Candidate nodes: interior vertices with 3 incident regions.
    let nv = mesh.vertices.len();
    let mut incident: Vec<Vec<usize>> = vec![Vec::new(); nv];
    for (r, cyc) in mesh.regions.iter().enumerate() {
        for &v in cyc {
            incident[v].push(r);
        }
    }
    let margin = 0.5 * sy;
    let interior = |p: Point| p[0] > margin && p[1] > margin && p[0] < w - margin && p[1] < h - margin;
    let mut tr = Rng::derived(seed, "scales_diag", "triangles");
    let mut chosen = vec![false; nv];
    let mut blocked = vec![false; nv];
    let mut groups = vec![0u32; ncells];
    for v in 0..nv {
        let pick = tr.next_f64() < params.triangle_fraction;
        if !pick || blocked[v] || incident[v].len() != 3 || !interior(mesh.vertices[v]) {
            continue;
        }
        // Neighbours of v (the vertices before and after it in its regions).
        let mut nbrs = Vec::new();
        for &r in &incident[v] {
            let cyc = &mesh.regions[r];
            let k = cyc.iter().position(|&x| x == v).expect("incident");
            let m = cyc.len();
            for u in [cyc[(k + m - 1) % m], cyc[(k + 1) % m]] {
                if !nbrs.contains(&u) {
                    nbrs.push(u);
                }
            }
        }
        if nbrs.len() != 3 || nbrs.iter().any(|&u| chosen[u] || blocked[u]) {
            continue;
        }
        chosen[v] = true;
        for &u in &nbrs {
            blocked[u] = true;
        }
    }
    for v in (0..nv).filter(|&v| chosen[v]) {
        let pv = mesh.vertices[v];
        let nbr_of = |r: usize, mesh: &Mesh| {
            let cyc = &mesh.regions[r];
            let m = cyc.len();
            let k = cyc.iter().position(|&x| x == v).expect("incident");
            (k, cyc[(k + m - 1) % m], cyc[(k + 1) % m])
        };
        let mut nbrs: Vec<usize> = Vec::new();
        for &r in &incident[v] {
            let (_, a, b) = nbr_of(r, &mesh);
            for u in [a, b] {
                if !nbrs.contains(&u) {
                    nbrs.push(u);
                }
            }
        }
        let min_len = nbrs
            .iter()
            .map(|&u| ((mesh.vertices[u][0] - pv[0]).powi(2) + (mesh.vertices[u][1] - pv[1]).powi(2)).sqrt())
            .fold(f64::INFINITY, f64::min);
        let d = (0.35 * min_len).min(0.3 * sy);
        let mut new_id = HashMap::new();
        for &u in &nbrs {
            let pu = mesh.vertices[u];
            let len = ((pu[0] - pv[0]).powi(2) + (pu[1] - pv[1]).powi(2)).sqrt();
            mesh.vertices.push([pv[0] + d * (pu[0] - pv[0]) / len, pv[1] + d * (pu[1] - pv[1]) / len]);
            new_id.insert(u, mesh.vertices.len() - 1);
        }
        for &r in &incident[v] {
            let (k, a, b) = nbr_of(r, &mesh);
            mesh.regions[r].splice(k..=k, [new_id[&a], new_id[&b]]);
        }
        let mut tri: Vec<usize> = nbrs.iter().map(|u| new_id[u]).collect();
        let pts: Vec<Point> = tri.iter().map(|&i| mesh.vertices[i]).collect();
        if signed_area(&pts) < 0.0 {
            tri.reverse();
        }
        mesh.regions.push(tri);
        groups.push(1);
    }
    let mesh = compact(&mesh);
    let classes = vec![0; mesh.regions.len()];
    finish("scales_diag", params.width, params.height, mesh, classes, groups, None)
}

// ---------------------------------------------------------------------------------------
// Occupancy

/// A facade occupancy mask (`w × h`, row-major): 1 on the wall, 0 in the openings: two rows
/// of three windows (each `w/8 × h/5`, centred at `x = 0.2w, 0.5w, 0.8w`, rows from
/// `y = 0.12h` and `0.42h`) and a door (`w/7` wide, from `y = 0.68h` to the bottom,
/// centred). Pixel `(i, j)` is in an opening if its centre is.
pub fn facade_occupancy(w: usize, h: usize) -> Vec<f32> {
    let (wf, hf) = (w as f64, h as f64);
    let mut rects: Vec<[f64; 4]> = Vec::new();
    for row in [0.12, 0.42] {
        for col in [0.2, 0.5, 0.8] {
            let (cw, ch) = (wf / 8.0, hf / 5.0);
            rects.push([col * wf - cw / 2.0, row * hf, col * wf + cw / 2.0, row * hf + ch]);
        }
    }
    rects.push([0.5 * wf - wf / 14.0, 0.68 * hf, 0.5 * wf + wf / 14.0, hf]);
    let mut out = vec![1.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            if rects.iter().any(|r| px >= r[0] && px < r[2] && py >= r[1] && py < r[3]) {
                out[y * w + x] = 0.0;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::structure::ellipse::{anisotropy, fit_polygon};
    use crate::synth::structure::faces::extract_faces;

    /// Valid, nothing to clean, faces = mesh regions (as cycles), areas tile the rectangle.
    fn check(s: &StandIn) {
        let cleaned = validate::clean(&s.subdivision).unwrap_or_else(|e| panic!("{}: {e}", s.name));
        assert!(cleaned.warnings.is_empty(), "{}: {:?}", s.name, cleaned.warnings);
        let f = extract_faces(&s.subdivision);
        assert!(f.euler_holds(), "{}", s.name);
        assert_eq!(f.regions.len(), s.mesh.regions.len(), "{}", s.name);
        let canon = |c: &[usize]| {
            let k = (0..c.len()).min_by_key(|&i| c[i]).unwrap();
            let mut v = c.to_vec();
            v.rotate_left(k);
            v
        };
        let mut a: Vec<Vec<usize>> = f.regions.iter().map(|r| canon(&r.boundary)).collect();
        let mut b: Vec<Vec<usize>> = s.mesh.regions.iter().map(|c| canon(c)).collect();
        a.sort();
        b.sort();
        assert_eq!(a, b, "{}: faces differ from the mesh", s.name);
        let total: f64 = f.regions.iter().map(|r| r.area).sum();
        let full = (s.width * s.height) as f64;
        assert!((total - full).abs() < 1e-6 * full, "{}: area {total} vs {full}", s.name);
        assert_eq!(s.classes.len(), s.mesh.regions.len());
        assert_eq!(s.groups.len(), s.mesh.regions.len());
        if let Some(d) = &s.density {
            assert_eq!(d.len(), s.width * s.height);
        }
    }

    #[test]
    fn wall_random_is_valid_with_exact_count() {
        for seed in [1, 2, 3] {
            let s = wall_random(&WallRandomParams::default(), seed);
            check(&s);
            assert_eq!(s.mesh.regions.len(), 100);
            assert_eq!(s.groups.iter().filter(|&&g| g == 0).count(), 30);
        }
        // Deterministic.
        assert_eq!(wall_random(&WallRandomParams::default(), 5), wall_random(&WallRandomParams::default(), 5));
        let p = WallRandomParams { count: 40, width: 256, height: 256, ..Default::default() };
        assert_eq!(wall_random(&p, 9).mesh.regions.len(), 40);
    }

    #[test]
    fn wall_layered_is_valid() {
        let s = wall_layered(&WallLayeredParams::default(), 1);
        check(&s);
        let n = s.mesh.regions.len();
        // 8 courses of about 512 / (2.25 · 56) ≈ 4 stones each.
        assert!((24..=64).contains(&n), "{n}");
        assert_eq!(*s.groups.iter().max().unwrap(), 7);
        assert_eq!(s.classes.iter().filter(|&&c| c == 2).count(), 4);
        // Interior stones are elongated horizontally.
        let border = s.border_regions();
        let polys = s.polygons();
        let mut horizontal = 0;
        let mut total = 0;
        for (r, p) in polys.iter().enumerate() {
            if border[r] {
                continue;
            }
            let e = fit_polygon(p).unwrap();
            total += 1;
            if e.theta.min(PI - e.theta) < 20f64.to_radians() {
                horizontal += 1;
            }
        }
        assert!(total > 5 && horizontal == total, "{horizontal}/{total}");
    }

    #[test]
    fn wall_regular_is_valid_with_upright_blocks() {
        let s = wall_regular(&WallRegularParams::default(), 1);
        check(&s);
        let polys = s.polygons();
        let mut upright_vertical = 0;
        let mut uprights = 0;
        for (r, p) in polys.iter().enumerate() {
            let e = fit_polygon(p).unwrap();
            let vertical = (e.theta - PI / 2.0).abs() < 0.2;
            if s.groups[r] == 1 {
                uprights += 1;
                upright_vertical += usize::from(vertical);
            } else if !s.border_regions()[r] {
                assert!(!vertical, "normal block {r} is upright");
            }
        }
        assert!(uprights >= 5, "{uprights}");
        // Upright blocks cut by the wall border may be wider than tall.
        assert!(upright_vertical as f64 >= 0.8 * uprights as f64, "{upright_vertical}/{uprights}");
        assert_eq!(s.mesh.regions.len(), s.groups.len());
    }

    #[test]
    fn cells_iso_is_valid_with_stated_count() {
        let s = cells_iso(&CellsIsoParams::default(), 1);
        check(&s);
        assert_eq!(s.mesh.regions.len(), 210);
        assert_eq!(s.groups.iter().filter(|&&g| g == 1).count(), 10);
        // Isotropic cells: mean anisotropy close to 1, valency 3 everywhere inside.
        let polys = s.polygons();
        let mean_aniso: f64 =
            polys[..200].iter().map(|p| anisotropy(polygon_moments(p).unwrap().cov)).sum::<f64>() / 200.0;
        assert!(mean_aniso < 1.6, "{mean_aniso}");
        for p in &polys[200..] {
            assert_eq!(p.len(), 3);
        }
    }

    #[test]
    fn scales_diag_is_valid() {
        let s = scales_diag(&ScalesDiagParams::default(), 1);
        check(&s);
        assert_eq!((s.width, s.height), (400, 270));
        let tris = s.groups.iter().filter(|&&g| g == 1).count();
        let scales = s.groups.len() - tris;
        assert!((80..=220).contains(&scales), "{scales}");
        assert!(tris >= 5, "{tris}");
        // Interior scales are elongated along 30°: exactly for untouched hexagons, within a
        // few degrees for those with a corner cut by a triangle or grown by a merged sliver.
        let border = s.border_regions();
        let polys = s.polygons();
        let tri_vertices: Vec<usize> =
            s.mesh.regions.iter().zip(&s.groups).filter(|(_, &g)| g == 1).flat_map(|(c, _)| c.clone()).collect();
        let (mut exact, mut cut) = (0, 0);
        for (r, p) in polys.iter().enumerate() {
            if border[r] || s.groups[r] == 1 {
                continue;
            }
            let e = fit_polygon(p).unwrap();
            assert!(e.a / e.b > 1.4, "{}", e.a / e.b);
            let dt = (e.theta - 30f64.to_radians()).abs().to_degrees();
            // Hexagons next to a merged border sliver or a triangle are not exact.
            if p.len() != 6 || s.mesh.regions[r].iter().any(|v| tri_vertices.contains(v)) {
                cut += 1;
                assert!(dt < 6.0, "cut scale {r}: θ off by {dt}°");
            } else {
                exact += 1;
                assert!(dt < 1e-6, "scale {r}: θ off by {dt}°");
            }
        }
        assert!(exact > 20 && cut > 5, "{exact} {cut}");
    }

    #[test]
    fn facade_mask() {
        let m = facade_occupancy(200, 100);
        let open = m.iter().filter(|&&v| v == 0.0).count();
        // 6 windows of 25×20 and a door of ~28.6×32.
        assert!((3800..4100).contains(&open), "{open}");
        assert_eq!(m[0], 1.0);
        assert_eq!(m[99 * 200 + 100], 0.0);
    }
}
