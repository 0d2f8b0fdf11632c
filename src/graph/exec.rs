//! The scheduler: computes keys, loads what the cache has, runs what it lacks.
//!
//! Only the values a target needs are touched: a cached output whose inputs are also cached
//! loads one entry and runs nothing. Stages that must run are grouped in waves by depth and
//! each wave runs in parallel on rayon. A stage's result depends only on its inputs, never
//! on which thread ran it or in what order, so outputs do not depend on the thread count.

use std::collections::{BTreeSet, HashMap, HashSet};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use super::budget::Budget;
use super::cache::{Cache, Lookup};
use super::key::{Key, KeyBuilder};
use super::progress::Progress;
use super::remote::{Entry, Remote, Traffic};
use super::stage::{Artifact, Graph, NodeId, RunCx, StageError};
use super::stats::Stats;
use super::world::World;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Not needed: everything downstream of it was cached.
    Fresh,
    /// Loaded from the on-disk cache.
    Hit,
    /// Loaded from the remote cache (and kept in the local one).
    Remote,
    /// Taken from the in-memory cache (watch mode).
    Memory,
    /// Ran.
    Ran,
    /// Ran because its cache entry failed verification.
    Rebuilt,
}

#[derive(Clone, Debug, Serialize)]
pub struct StageRecord {
    pub node: NodeId,
    pub label: String,
    pub kind: &'static str,
    #[serde(serialize_with = "key_hex")]
    pub key: Key,
    pub status: Status,
    pub millis: f64,
    /// Bytes fetched from the remote cache for this stage.
    #[serde(skip_serializing_if = "is_zero")]
    pub bytes_down: u64,
    /// Bytes sent to the remote cache for this stage (once the upload finished).
    #[serde(skip_serializing_if = "is_zero")]
    pub bytes_up: u64,
    /// What the stage warned about: when it ran, or, when it was loaded or not needed, when
    /// it ran for the cache entry (kept beside the entry, under `Key::warnings`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

fn key_hex<S: serde::Serializer>(k: &Key, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&k.hex())
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct Report {
    pub stages: Vec<StageRecord>,
}

impl Report {
    /// This build's counts for `tessera cache stats`, with the remote traffic it caused.
    pub fn stats(&self, traffic: Traffic) -> Stats {
        let count = |f: fn(Status) -> bool| self.stages.iter().filter(|s| f(s.status)).count() as u64;
        Stats {
            builds: 1,
            needed: count(|s| s != Status::Fresh),
            local_hits: count(|s| matches!(s, Status::Hit | Status::Memory)),
            remote_hits: count(|s| s == Status::Remote),
            computed: self.ran().count() as u64,
            remote_lookups: traffic.lookups,
            bytes_down: traffic.bytes_down,
            bytes_up: traffic.bytes_up,
            remote_faults: u64::from(traffic.faults > 0),
        }
    }

    pub fn ran(&self) -> impl Iterator<Item = &StageRecord> {
        self.stages.iter().filter(|s| matches!(s.status, Status::Ran | Status::Rebuilt))
    }
}

#[derive(Debug)]
pub struct Failure {
    pub node: NodeId,
    pub error: StageError,
}

/// Artifacts kept between builds in watch mode, so an unchanged stage is not even decoded.
#[derive(Default)]
pub struct MemoryCache {
    map: Mutex<HashMap<Key, Artifact>>,
}

impl MemoryCache {
    fn get(&self, k: &Key) -> Option<Artifact> {
        self.map.lock().expect("memory cache lock").get(k).cloned()
    }

    fn put(&self, k: Key, a: Artifact) {
        self.map.lock().expect("memory cache lock").insert(k, a);
    }

    /// Drops everything not used by the last build.
    pub fn retain(&self, keep: &HashSet<Key>) {
        self.map.lock().expect("memory cache lock").retain(|k, _| keep.contains(k));
    }
}

pub struct Executor<'a> {
    pub world: &'a World,
    pub cache: &'a Cache,
    pub memory: Option<&'a MemoryCache>,
    /// The shared cache under the local one, if any.
    pub remote: Option<&'a Arc<Remote>>,
    pub progress: bool,
    /// Handed to stages through [`RunCx::budget`]; no part of any key.
    pub budget: Budget,
}

pub struct Outcome {
    pub values: HashMap<NodeId, Artifact>,
    pub keys: HashMap<NodeId, Key>,
    pub report: Report,
}

impl Outcome {
    /// The value of a node the run computed or loaded, as its handle's type.
    pub fn get<T: std::any::Any + Send + Sync>(&self, h: super::stage::Handle<T>) -> Option<std::sync::Arc<T>> {
        self.values.get(&h.node()).and_then(|v| v.clone().downcast::<T>().ok())
    }
}

impl Executor<'_> {
    /// Computes the key of every node in `nodes` (ascending, so inputs come first).
    pub fn keys(&self, graph: &Graph, nodes: &[NodeId]) -> Result<HashMap<NodeId, Key>, Failure> {
        let mut keys: HashMap<NodeId, Key> = HashMap::with_capacity(nodes.len());
        for &n in nodes {
            let node = &graph.nodes[n];
            let mut kb = KeyBuilder::new(node.stage.kind(), node.stage.version());
            kb.part(node.stage.params().as_bytes());
            for i in &node.inputs {
                kb.part(&keys[i].0);
            }
            for (fi, f) in node.files.iter().enumerate() {
                let h = self.world.hash(f).map_err(|e| Failure {
                    node: n,
                    error: StageError::new(format!("cannot read `{}`: {e}", f.display())).in_file(fi),
                })?;
                kb.part(&h);
            }
            keys.insert(n, kb.finish());
        }
        Ok(keys)
    }

    pub fn run(&self, graph: &Graph, targets: &[NodeId]) -> Result<Outcome, (Failure, Report)> {
        let closure = graph.closure(targets);
        let keys = self.keys(graph, &closure).map_err(|f| (f, Report::default()))?;
        let mut status: HashMap<NodeId, (Status, f64)> = HashMap::new();
        let mut warnings: HashMap<NodeId, Vec<String>> = HashMap::new();
        let mut values: HashMap<NodeId, Artifact> = HashMap::new();
        let mut corrupt: HashSet<NodeId> = HashSet::new();
        let mut bytes_down: HashMap<NodeId, u64> = HashMap::new();
        // The remote's entries for stages the local cache lacks, and the stages asked for.
        let mut remote: HashMap<NodeId, Entry> = HashMap::new();
        let mut asked: HashSet<NodeId> = HashSet::new();
        let mut consumers: HashMap<NodeId, Vec<NodeId>> = HashMap::new();
        if self.remote.is_some() {
            for &n in &closure {
                for &i in &graph.nodes[n].inputs {
                    consumers.entry(i).or_default().push(n);
                }
            }
        }

        // Decide what to load and what to run; a load that fails verification turns into
        // a run, which may need more inputs, so iterate until every load succeeds. Stages
        // to run are first looked up in the remote; a hit there may spare its inputs.
        let to_run = loop {
            let (load, run) = self.plan(graph, targets, &keys, &values, &corrupt, &remote);
            if let Some(r) = self.remote.filter(|r| r.active()) {
                // Top down: a stage is asked for once every stage to run that reads it was
                // asked and missed, so a hit spares the lookups of everything below it.
                let ready = |n: &NodeId| {
                    !asked.contains(n)
                        && consumers
                            .get(n)
                            .is_none_or(|cs| cs.iter().filter(|c| run.contains(c)).all(|c| asked.contains(c)))
                };
                let ask: Vec<NodeId> = run.iter().copied().filter(ready).collect();
                if !ask.is_empty() {
                    asked.extend(&ask);
                    let found: Vec<(NodeId, Entry)> =
                        ask.par_iter().filter_map(|&n| r.lookup(&keys[&n]).map(|e| (n, e))).collect();
                    remote.extend(found);
                    continue;
                }
            }
            type Loaded = (NodeId, Option<(Artifact, Status, u64)>, f64);
            let loaded: Vec<Loaded> = load
                .par_iter()
                .map(|&n| {
                    let t = Instant::now();
                    let r = self.load(graph, n, &keys[&n], remote.get(&n));
                    (n, r, ms(t))
                })
                .collect();
            let mut again = false;
            for (n, r, t) in loaded {
                match r {
                    Some((a, s, bytes)) => {
                        values.insert(n, a);
                        status.insert(n, (s, t));
                        if bytes > 0 {
                            bytes_down.insert(n, bytes);
                        }
                    }
                    None => {
                        // Not usable locally nor remotely: run it.
                        if remote.remove(&n).is_none() {
                            corrupt.insert(n);
                        }
                        again = true;
                    }
                }
            }
            if !again {
                break run;
            }
        };

        // Waves by depth within the set to run.
        let mut depth: HashMap<NodeId, usize> = HashMap::new();
        for &n in &to_run {
            let d = graph.nodes[n].inputs.iter().filter_map(|i| depth.get(i)).map(|d| d + 1).max().unwrap_or(0);
            depth.insert(n, d);
        }
        let max_depth = depth.values().copied().max();
        let mut failure: Option<Failure> = None;
        if let Some(max_depth) = max_depth {
            for level in 0..=max_depth {
                let wave: Vec<NodeId> = to_run.iter().copied().filter(|n| depth[n] == level).collect();
                type Ran = (NodeId, Result<Artifact, StageError>, f64, Vec<String>);
                let results: Vec<Ran> = wave
                    .par_iter()
                    .map(|&n| {
                        let t = Instant::now();
                        let (r, w) = self.execute(graph, n, &keys[&n], &values);
                        (n, r, ms(t), w)
                    })
                    .collect();
                for (n, r, t, w) in results {
                    if !w.is_empty() {
                        warnings.insert(n, w);
                    }
                    match r {
                        Ok(a) => {
                            values.insert(n, a);
                            let s = if corrupt.contains(&n) { Status::Rebuilt } else { Status::Ran };
                            status.insert(n, (s, t));
                        }
                        Err(e) => {
                            if failure.as_ref().is_none_or(|f| n < f.node) {
                                failure = Some(Failure { node: n, error: e });
                            }
                        }
                    }
                }
                if failure.is_some() {
                    break;
                }
            }
        }

        let report = Report {
            stages: closure
                .iter()
                .filter_map(|&n| {
                    let node = &graph.nodes[n];
                    let (s, t) = match status.get(&n) {
                        Some(st) => *st,
                        None if failure.is_some() && to_run.contains(&n) => return None,
                        None => (Status::Fresh, 0.0),
                    };
                    Some(StageRecord {
                        node: n,
                        label: node.label.clone(),
                        kind: node.stage.kind(),
                        key: keys[&n],
                        status: s,
                        millis: t,
                        bytes_down: bytes_down.get(&n).copied().unwrap_or(0),
                        bytes_up: 0,
                        warnings: warnings.remove(&n).unwrap_or_else(|| self.cached_warnings(s, &keys[&n])),
                    })
                })
                .collect(),
        };
        if let Some(f) = failure {
            return Err((f, report));
        }
        if let Some(mem) = self.memory {
            for (n, v) in &values {
                mem.put(keys[n], v.clone());
            }
        }
        let values = targets.iter().map(|t| (*t, values[t].clone())).collect();
        Ok(Outcome { values, keys, report })
    }

    /// Which nodes to load from a cache and which to run, given what is already in hand.
    fn plan(
        &self,
        graph: &Graph,
        targets: &[NodeId],
        keys: &HashMap<NodeId, Key>,
        have: &HashMap<NodeId, Artifact>,
        corrupt: &HashSet<NodeId>,
        remote: &HashMap<NodeId, Entry>,
    ) -> (Vec<NodeId>, BTreeSet<NodeId>) {
        let mut need: BTreeSet<NodeId> = targets.iter().copied().collect();
        let mut load = Vec::new();
        let mut run = BTreeSet::new();
        // Descending ids visit every consumer before its inputs.
        while let Some(n) = need.pop_last() {
            if have.contains_key(&n) {
                continue;
            }
            let k = &keys[&n];
            let cached = remote.contains_key(&n)
                || !corrupt.contains(&n) && (self.memory.is_some_and(|m| m.get(k).is_some()) || self.cache.contains(k));
            if cached {
                load.push(n);
            } else {
                run.insert(n);
                need.extend(graph.nodes[n].inputs.iter().copied());
            }
        }
        (load, run)
    }

    /// A stage's value from memory, the local cache or (given its entry) the remote, with
    /// the bytes the remote sent.
    fn load(&self, graph: &Graph, n: NodeId, key: &Key, entry: Option<&Entry>) -> Option<(Artifact, Status, u64)> {
        if let Some(a) = self.memory.and_then(|m| m.get(key)) {
            return Some((a, Status::Memory, 0));
        }
        let stage = &graph.nodes[n].stage;
        if let Lookup::Hit(bytes) = self.cache.get(key) {
            if let Ok(a) = stage.decode(&bytes) {
                return Some((a, Status::Hit, 0));
            }
        }
        let (remote, entry) = (self.remote?, entry?);
        let payload = remote.fetch(&entry.payload)?;
        let warnings = match &entry.warnings {
            Some(w) => Some(remote.fetch(w)?),
            None => None,
        };
        let Ok(artifact) = stage.decode(&payload) else {
            // Verified bytes that do not decode: a payload of another build of tessera.
            return None;
        };
        let moved = (payload.len() + warnings.as_ref().map_or(0, Vec::len)) as u64;
        // Verified, so safe to keep; a local cache that cannot be written costs speed only.
        let _ = self.cache.put(key, &payload);
        if let Some(w) = warnings.filter(|w| serde_json::from_slice::<Vec<String>>(w).is_ok()) {
            let _ = self.cache.put(&key.warnings(), &w);
        }
        Some((artifact, Status::Remote, moved))
    }

    fn execute(
        &self,
        graph: &Graph,
        n: NodeId,
        key: &Key,
        values: &HashMap<NodeId, Artifact>,
    ) -> (Result<Artifact, StageError>, Vec<String>) {
        let node = &graph.nodes[n];
        let progress = Progress::new(&node.label, self.progress);
        let cx = RunCx {
            inputs: node.inputs.iter().map(|i| values[i].clone()).collect(),
            files: &node.files,
            world: self.world,
            budget: self.budget,
            progress: &progress,
            warnings: Default::default(),
        };
        let result = node.stage.run(&cx);
        progress.finish();
        let warnings = cx.warnings.into_inner().unwrap_or_default();
        let artifact = match result {
            Ok(a) => a,
            Err(e) => return (Err(e), warnings),
        };
        // A cache that cannot be written costs speed, not correctness: carry on.
        let payload = node.stage.encode(&artifact);
        let _ = self.cache.put(key, &payload);
        let warnings_json = (!warnings.is_empty()).then(|| serde_json::to_vec(&warnings).unwrap_or_default());
        if let Some(w) = &warnings_json {
            let _ = self.cache.put(&key.warnings(), w);
        }
        if let Some(r) = self.remote {
            r.upload(*key, payload, warnings_json);
        }
        (Ok(artifact), warnings)
    }

    /// The warnings a stage that did not run gave when it ran for its cache entry.
    fn cached_warnings(&self, status: Status, key: &Key) -> Vec<String> {
        match status {
            Status::Hit | Status::Remote | Status::Memory | Status::Fresh => self.cache.warnings(key),
            Status::Ran | Status::Rebuilt => Vec::new(),
        }
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1000.0
}
