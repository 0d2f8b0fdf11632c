//! Smooth transformations between textures ([references: bourque §ch5]): a sequence of frames
//! from one key texture to the next, within one shader or across shaders.
//!
//! ```text
//! catalogues + jump points ─► linked graph ─► p-norm path per leg (Eq. 5.1)
//!     ─► unsearched values blended along each shader's stretch ─► midpoint subdivision
//!     ─► frames with times
//! ```
//!
//! - **Graph**: every catalogue is a fully connected graph (edge length `1 − S'`, the
//!   catalogue's calibrated similarity); each jump point adds a vertex to both its shaders'
//!   graphs and the jump edge between them (`1 − S'` under the pair's calibration). Each
//!   leg's two keys join their shaders' graphs the same way, so the path starts from the
//!   catalogue vertex nearest the key, or from none if the key is closer to the next stop
//!   ([references: bourque §ch5.2]).
//! - **Path**: [`pnorm_path`] from key to key; legs are solved apart and concatenated, each
//!   inner key appearing once.
//! - **Stretches**: the renders a catalogue holds differ from a key in what the search does not
//!   move (colours); along each run of one shader those values go linearly from the run's
//!   first stop to its last, taken from the key at either end (defaults where neither is one).
//! - **Subdivision** (Fig. 5-3): while two neighbours are less alike than `τ`, the midpoint of
//!   their parameter vectors is inserted, down to `depth` halvings; never across a jump (its
//!   ends live in different spaces). Segments still below `τ` are reported.
//! - **Timing**: `t` grows by `1 − S'` from each frame to the next, normalised to `[0, 1]`.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::catalogue::{largest, Catalogue};
use super::jump::JumpSet;
use super::path::{pnorm_path, Graph};
use super::probe::{feature, similarity, Feature};
use super::search::Candidate;
use crate::raster::Image;
use crate::synth::metrics::Calibration;
use crate::synth::shader::{self as lib, ParamKind, ShaderDef};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransformConfig {
    /// `n` of Eq. 5.1.
    pub exponent: f64,
    /// Calibrated similarity neighbouring frames of one shader should reach.
    pub tau: f64,
    /// Halvings of one path edge at most.
    pub depth: usize,
    /// Frames inserted by subdivision over the whole transformation at most.
    pub budget: usize,
    /// The spatially selective term ([references: bourque §ch6]): neighbouring frames of one
    /// shader are also halved while their pixels differ by more than this (root mean square
    /// over a 32² thumbnail of luminance), so positions change little from frame to frame.
    pub coherence: Option<f64>,
}

impl Default for TransformConfig {
    fn default() -> Self {
        TransformConfig { exponent: 3.0, tau: 0.95, depth: 10, budget: 2000, coherence: None }
    }
}

/// A key texture: a shader of the transformation's set and its flat parameter vector.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Key {
    pub shader: usize,
    pub values: Vec<f64>,
}

/// The jump points between two shaders of the set.
pub struct Link<'a> {
    pub a: usize,
    pub b: usize,
    pub jumps: &'a JumpSet,
}

/// One frame of a transformation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    pub shader: usize,
    pub values: Vec<f64>,
    /// Time in `[0, 1]`.
    pub t: f64,
    /// Calibrated similarity to the previous frame (1 for the first).
    pub score: f64,
    /// The key it shows, if it is one.
    pub key: Option<usize>,
    /// The shader changes between the previous frame and this one.
    pub jump: bool,
}

/// A transformation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Transformation {
    pub frames: Vec<Frame>,
    /// Frames `i` whose similarity to frame `i − 1` stayed below `τ` within one shader.
    pub failed: Vec<usize>,
    /// The p-norm cost of each leg's graph path.
    pub costs: Vec<f64>,
    /// Frames added by subdivision, and renders made.
    pub inserted: usize,
    pub renders: usize,
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TransformError {
    #[error("a transformation needs at least two keys")]
    TooFewKeys,
    #[error("no path joins key {from} to key {to}: no chain of jump points links their shaders")]
    NoPath { from: usize, to: usize },
}

/// A stop of a path: a shader, its values, their render's feature and luminance thumbnail.
#[derive(Clone)]
pub struct Stop {
    pub shader: usize,
    pub values: Vec<f64>,
    pub feature: Feature,
    pub thumb: Vec<f32>,
    pub key: Option<usize>,
}

/// Side of the thumbnails the coherence term compares.
const THUMB: usize = 32;

/// Renders of the set's shaders, as a path's stops need them.
struct Renderer<'a> {
    shapes: &'a [Candidate<'a>],
}

impl Renderer<'_> {
    fn def(&self, shader: usize) -> &'static ShaderDef {
        self.shapes[shader].probe.space.shader
    }

    fn stop(&self, shader: usize, values: Vec<f64>, key: Option<usize>) -> Stop {
        let p = &self.shapes[shader].probe;
        let img = lib::render_square(p.space.shader, &values, p.seed, p.side).expect("values of the shader's table");
        Stop { shader, feature: feature(&img, &p.metric), thumb: thumbnail(&img), values, key }
    }

    /// Calibrated similarity within one shader.
    fn within(&self, a: &Stop, b: &Stop) -> f64 {
        self.shapes[a.shader].catalogue.calibration.apply(similarity(&a.feature, &b.feature))
    }
}

/// The catalogue vertex most like `f` (the thesis's link from an endpoint to its shader's
/// graph, Sec. 5.2; a leg's graph joins its keys to every vertex, which includes this one).
pub fn nearest_vertex(f: &Feature, catalogue: &Catalogue<Feature>) -> Option<usize> {
    let s: Vec<f64> = catalogue.features.par_iter().map(|g| similarity(f, g)).collect();
    largest(&s, 0..s.len())
}

/// Luminance box-averaged to `THUMB²`.
fn thumbnail(img: &Image) -> Vec<f32> {
    let mut out = vec![0.0f32; THUMB * THUMB];
    let mut count = vec![0u32; THUMB * THUMB];
    for y in 0..img.height {
        for x in 0..img.width {
            let l = 0.2126 * img.get(x, y, 0) + 0.7152 * img.get(x, y, 1) + 0.0722 * img.get(x, y, 2);
            let k = (y * THUMB / img.height) * THUMB + x * THUMB / img.width;
            out[k] += l;
            count[k] += 1;
        }
    }
    out.iter().zip(&count).map(|(s, &n)| if n > 0 { s / n as f32 } else { 0.0 }).collect()
}

/// Root mean square difference of two thumbnails.
pub fn thumb_rms(a: &[f32], b: &[f32]) -> f64 {
    (a.iter().zip(b).map(|(p, q)| ((p - q) as f64).powi(2)).sum::<f64>() / a.len().max(1) as f64).sqrt()
}

/// The midpoint of two flat vectors of one shader, whole-number parameters rounded; `None`
/// when it is one of the two (nothing lies between).
pub fn midpoint(def: &ShaderDef, a: &[f64], b: &[f64]) -> Option<Vec<f64>> {
    let mut m: Vec<f64> = a.iter().zip(b).map(|(p, q)| 0.5 * (p + q)).collect();
    let mut at = 0;
    for p in def.params {
        if matches!(p.kind, ParamKind::Int { .. }) {
            m[at] = m[at].round();
        }
        at += p.kind.width();
    }
    (m != a && m != b).then_some(m)
}

/// How a gap between two neighbouring stops stands during subdivision.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Gap {
    /// May still be halved this many more times.
    Open(usize),
    Close,
    Failed,
    /// Between shaders: never halved.
    Jump,
}

/// The result of [`subdivide`].
pub struct Subdivision<P> {
    pub points: Vec<P>,
    /// Indices `i` of the gaps `(i − 1, i)` left open (not close enough at the depth cap, or
    /// with nothing between their ends).
    pub failed: Vec<usize>,
    pub inserted: usize,
}

/// Adaptive midpoint subdivision (Fig. 5-3), breadth first: every gap that `splittable` allows
/// and that is not `close` gets its `mid` point, level by level, at most `depth` levels and
/// `budget` points in all (the earliest gaps first once it runs short). Midpoints of a level
/// are computed in parallel; which gaps are halved depends only on the points, so the result
/// does not depend on the thread count.
pub fn subdivide<P: Send + Sync>(
    points: Vec<P>,
    splittable: impl Fn(&P, &P) -> bool,
    close: impl Fn(&P, &P) -> bool + Sync,
    mid: impl Fn(&P, &P) -> Option<P> + Sync,
    depth: usize,
    budget: usize,
) -> Subdivision<P> {
    let mut points = points;
    let mut gaps: Vec<Gap> =
        points.windows(2).map(|w| if splittable(&w[0], &w[1]) { Gap::Open(depth) } else { Gap::Jump }).collect();
    let mut inserted = 0;
    loop {
        let open: Vec<usize> = (0..gaps.len()).filter(|&i| matches!(gaps[i], Gap::Open(_))).collect();
        if open.is_empty() {
            break;
        }
        let mids: Vec<Option<Option<P>>> = open
            .par_iter()
            .map(|&i| {
                if close(&points[i], &points[i + 1]) {
                    None
                } else if gaps[i] == Gap::Open(0) {
                    // Failed either way: no render for a midpoint that cannot be kept.
                    Some(None)
                } else {
                    Some(mid(&points[i], &points[i + 1]))
                }
            })
            .collect();
        let mut new_points = Vec::with_capacity(points.len() * 2);
        let mut new_gaps = Vec::with_capacity(gaps.len() * 2);
        let mut mids = open.iter().copied().zip(mids).peekable();
        for (i, p) in points.into_iter().enumerate() {
            new_points.push(p);
            let Some(&g) = gaps.get(i) else { break };
            let outcome = if mids.peek().is_some_and(|(j, _)| *j == i) { mids.next().map(|(_, m)| m) } else { None };
            match (g, outcome) {
                (Gap::Open(_), Some(None)) => new_gaps.push(Gap::Close),
                (Gap::Open(_), Some(Some(None))) => new_gaps.push(Gap::Failed),
                (Gap::Open(d), Some(Some(Some(m)))) => {
                    if inserted < budget {
                        inserted += 1;
                        new_points.push(m);
                        new_gaps.push(Gap::Open(d - 1));
                        new_gaps.push(Gap::Open(d - 1));
                    } else {
                        new_gaps.push(Gap::Failed);
                    }
                }
                (g, _) => new_gaps.push(g),
            }
        }
        points = new_points;
        gaps = new_gaps;
    }
    let failed = gaps.iter().enumerate().filter(|(_, g)| **g == Gap::Failed).map(|(i, _)| i + 1).collect();
    Subdivision { points, failed, inserted }
}

/// The node of a leg's graph: a catalogue vertex, or a stop of its own.
enum Node {
    Vertex { shader: usize, index: usize },
    Own(Stop),
}

/// The transformation through `keys` (see the module documentation). `shapes` are the
/// shaders of the set with their catalogues; `links` the jump points between pairs of them.
pub fn transform(
    shapes: &[Candidate],
    links: &[Link],
    keys: &[Key],
    cfg: &TransformConfig,
) -> Result<Transformation, TransformError> {
    if keys.len() < 2 {
        return Err(TransformError::TooFewKeys);
    }
    let r = Renderer { shapes };
    let mut renders = 0;
    let key_stops: Vec<Stop> =
        keys.par_iter().enumerate().map(|(k, key)| r.stop(key.shader, key.values.clone(), Some(k))).collect();
    renders += keys.len();

    // The graph every leg shares: catalogue vertices, jump vertices and jump edges.
    let mut nodes: Vec<Node> = Vec::new();
    let mut first = Vec::new();
    for (s, c) in shapes.iter().enumerate() {
        first.push(nodes.len());
        nodes.extend((0..c.catalogue.len()).map(|index| Node::Vertex { shader: s, index }));
    }
    let mut jump_edges = Vec::new();
    for link in links {
        for j in &link.jumps.points {
            let pa = &shapes[link.a].probe;
            let pb = &shapes[link.b].probe;
            let (a, b) = rayon::join(
                || r.stop(link.a, pa.space.values(&j.x), None),
                || r.stop(link.b, pb.space.values(&j.y), None),
            );
            renders += 2;
            nodes.push(Node::Own(a));
            nodes.push(Node::Own(b));
            jump_edges.push((nodes.len() - 2, nodes.len() - 1, 1.0 - link.jumps.calibration.apply(j.similarity)));
        }
    }
    let mut graph = Graph::new(nodes.len());
    for (s, c) in shapes.iter().enumerate() {
        let n = c.catalogue.len();
        for i in 0..n {
            for j in i + 1..n {
                graph.add_edge(first[s] + i, first[s] + j, 1.0 - c.catalogue.weight(i, j));
            }
        }
    }
    for &(a, b, e) in &jump_edges {
        graph.add_edge(a, b, e);
    }
    let owned: Vec<usize> = (0..nodes.len()).filter(|&i| matches!(nodes[i], Node::Own(_))).collect();
    for (k, &i) in owned.iter().enumerate() {
        let Node::Own(stop) = &nodes[i] else { unreachable!() };
        join_shader(&mut graph, &nodes, &first, shapes, i, stop, &owned[..k]);
    }

    let mut stops: Vec<Stop> = vec![key_stops[0].clone()];
    let mut costs = Vec::new();
    for leg in 0..keys.len() - 1 {
        let mut g = graph.clone();
        let mut leg_nodes: Vec<&Stop> = Vec::new();
        let base = nodes.len();
        for (k, stop) in [&key_stops[leg], &key_stops[leg + 1]].into_iter().enumerate() {
            let i = g.add_node();
            leg_nodes.push(stop);
            join_shader(&mut g, &nodes, &first, shapes, i, stop, &owned);
            if k == 1 && stop.shader == key_stops[leg].shader {
                let e = 1.0 - r.within(&key_stops[leg], stop);
                g.add_edge(base, i, e);
            }
        }
        let path =
            pnorm_path(&g, base, base + 1, cfg.exponent).ok_or(TransformError::NoPath { from: leg, to: leg + 1 })?;
        costs.push(path.cost);
        let leg_stops: Vec<Stop> = path
            .nodes
            .iter()
            .map(|&i| match nodes.get(i) {
                Some(Node::Vertex { shader, index }) => {
                    let c = &shapes[*shader];
                    Stop {
                        shader: *shader,
                        values: c.probe.space.values(&c.catalogue.points[*index]),
                        feature: c.catalogue.features[*index].clone(),
                        thumb: Vec::new(),
                        key: None,
                    }
                }
                Some(Node::Own(s)) => s.clone(),
                None => leg_nodes[i - base].clone(),
            })
            .collect();
        let mut leg_stops = blend_stretches(&r, leg_stops);
        // A key on a catalogue vertex joins it at distance 0: one frame, not two.
        leg_stops.dedup_by(|b, a| {
            let same = a.shader == b.shader && a.values == b.values;
            if same && a.key.is_none() {
                a.key = b.key;
            }
            same
        });
        // Catalogue vertices (no thumbnail kept) and stops whose values were blended are
        // rendered afresh.
        renders += leg_stops.iter().filter(|s| s.thumb.is_empty()).count();
        leg_stops.par_iter_mut().for_each(|s| {
            if s.thumb.is_empty() {
                *s = r.stop(s.shader, std::mem::take(&mut s.values), s.key);
            }
        });
        stops.extend(leg_stops.into_iter().skip(1));
    }

    let tau = cfg.tau;
    let sub = subdivide(
        stops,
        |a, b| a.shader == b.shader,
        |a, b| r.within(a, b) >= tau && cfg.coherence.is_none_or(|c| thumb_rms(&a.thumb, &b.thumb) <= c),
        |a, b| midpoint(r.def(a.shader), &a.values, &b.values).map(|m| r.stop(a.shader, m, None)),
        cfg.depth,
        cfg.budget,
    );
    renders += sub.inserted;
    let stops = sub.points;
    let jump_cal = |a: usize, b: usize| {
        links
            .iter()
            .find(|l| (l.a, l.b) == (a, b) || (l.a, l.b) == (b, a))
            .map_or(Calibration { d0: 1.0 }, |l| l.jumps.calibration)
    };
    let mut frames: Vec<Frame> = Vec::with_capacity(stops.len());
    for (i, s) in stops.iter().enumerate() {
        let score = match i.checked_sub(1).map(|p| &stops[p]) {
            None => 1.0,
            Some(p) if p.shader == s.shader => r.within(p, s),
            Some(p) => jump_cal(p.shader, s.shader).apply(similarity(&p.feature, &s.feature)),
        };
        let jump = i > 0 && stops[i - 1].shader != s.shader;
        frames.push(Frame { shader: s.shader, values: s.values.clone(), t: 0.0, score, key: s.key, jump });
    }
    let t = times(&frames.iter().map(|f| f.score).collect::<Vec<_>>());
    for (f, t) in frames.iter_mut().zip(t) {
        f.t = t;
    }
    Ok(Transformation { frames, failed: sub.failed, costs, inserted: sub.inserted, renders })
}

/// Joins a vertex of its own (a jump vertex) to its shader's catalogue and to the earlier own
/// vertices of the same shader.
fn join_shader(
    g: &mut Graph,
    nodes: &[Node],
    first: &[usize],
    shapes: &[Candidate],
    i: usize,
    stop: &Stop,
    others: &[usize],
) {
    let c = &shapes[stop.shader];
    let cal = c.catalogue.calibration;
    let e: Vec<f64> = c.catalogue.features.par_iter().map(|f| 1.0 - cal.apply(similarity(&stop.feature, f))).collect();
    for (v, e) in e.into_iter().enumerate() {
        g.add_edge(i, first[stop.shader] + v, e);
    }
    for &o in others {
        if let Node::Own(other) = &nodes[o] {
            if other.shader == stop.shader {
                g.add_edge(i, o, 1.0 - cal.apply(similarity(&stop.feature, &other.feature)));
            }
        }
    }
}

/// Gives each run of one shader's stops the unsearched values of its ends, blended linearly
/// (keys keep their own values).
fn blend_stretches(r: &Renderer, mut stops: Vec<Stop>) -> Vec<Stop> {
    let mut start = 0;
    while start < stops.len() {
        let shader = stops[start].shader;
        let mut end = start;
        while end + 1 < stops.len() && stops[end + 1].shader == shader {
            end += 1;
        }
        let space = &r.shapes[shader].probe.space;
        let searched: Vec<usize> = space.axes.iter().map(|a| a.index).collect();
        let unsearched = |v: &[f64]| -> Vec<f64> {
            v.iter().enumerate().map(|(i, &x)| if searched.contains(&i) { f64::NAN } else { x }).collect()
        };
        let own = |s: &Stop| s.key.map(|_| unsearched(&s.values));
        let (a, b) = (own(&stops[start]), own(&stops[end]));
        let defaults = unsearched(&space.base);
        let from = a.clone().or(b.clone()).unwrap_or(defaults.clone());
        let to = b.or(a).unwrap_or(defaults);
        let len = end - start;
        for (k, s) in stops[start..=end].iter_mut().enumerate() {
            if s.key.is_some() {
                continue;
            }
            let w = if len == 0 { 0.0 } else { k as f64 / len as f64 };
            let mut changed = false;
            for i in 0..s.values.len() {
                if !from[i].is_nan() {
                    let v = from[i] + w * (to[i] - from[i]);
                    changed |= v != s.values[i];
                    s.values[i] = v;
                }
            }
            if changed {
                s.thumb.clear();
            }
        }
        start = end + 1;
    }
    stops
}

/// Frame times from each frame's calibrated similarity to the previous one: `t` grows by
/// `1 − S'` (at least 1e-9, so it grows strictly), normalised to end at 1.
pub fn times(scores: &[f64]) -> Vec<f64> {
    let mut t = Vec::with_capacity(scores.len());
    let mut acc = 0.0;
    for (i, s) in scores.iter().enumerate() {
        if i > 0 {
            acc += (1.0 - s).max(1e-9);
        }
        t.push(acc);
    }
    if acc > 0.0 {
        for v in &mut t {
            *v /= acc;
        }
        if let Some(last) = t.last_mut() {
            *last = 1.0;
        }
    }
    t
}

/// The frames nearest `count` evenly spaced times (a frame may repeat when the path has fewer
/// than `count`).
pub fn resample(t: &[f64], count: usize) -> Vec<usize> {
    (0..count)
        .map(|k| {
            let want = if count > 1 { k as f64 / (count - 1) as f64 } else { 0.0 };
            let mut best = 0;
            for (i, &ti) in t.iter().enumerate() {
                if (ti - want).abs() < (t[best] - want).abs() {
                    best = i;
                }
            }
            best
        })
        .collect()
}
