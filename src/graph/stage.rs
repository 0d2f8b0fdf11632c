//! The unit of cached work.

use std::any::Any;
use std::path::PathBuf;
use std::sync::Arc;

use super::world::World;

/// A stage's result, shared between the stages that read it.
pub type Artifact = Arc<dyn Any + Send + Sync>;

/// Index of a node in a `Graph`.
pub type NodeId = usize;

/// Why a stage failed, in words for the user. The planner that built the graph knows which
/// declaration a node came from and attaches the scene span.
#[derive(Clone, Debug, PartialEq)]
pub struct StageError {
    pub message: String,
    pub help: Option<String>,
    /// Which input file, if the failure is about one (index into the node's `files`).
    pub file: Option<usize>,
    /// Which property of the declaration, if the failure is about one.
    pub prop: Option<&'static str>,
}

impl StageError {
    pub fn new(message: impl Into<String>) -> Self {
        StageError { message: message.into(), help: None, file: None, prop: None }
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    pub fn in_file(mut self, index: usize) -> Self {
        self.file = Some(index);
        self
    }

    pub fn at_prop(mut self, prop: &'static str) -> Self {
        self.prop = Some(prop);
        self
    }
}

/// A pure function of its inputs: other stages' artifacts, bytes of input files, and its
/// canonical parameters. Same key, same bytes; bump `version` when the output changes.
pub trait Stage: Send + Sync {
    /// A stable name such as `map.source`; part of the key.
    fn kind(&self) -> &'static str;
    fn version(&self) -> u32;
    /// Canonical text of every parameter the result depends on; part of the key.
    fn params(&self) -> String;
    fn run(&self, cx: &RunCx) -> Result<Artifact, StageError>;
    fn encode(&self, artifact: &Artifact) -> Vec<u8>;
    fn decode(&self, bytes: &[u8]) -> Result<Artifact, String>;
}

pub struct Node {
    /// What the user sees in reports: `map density`, `output a.png`.
    pub label: String,
    pub stage: Box<dyn Stage>,
    pub inputs: Vec<NodeId>,
    pub files: Vec<PathBuf>,
    /// The caller's tag for this node (the planner uses the declaration's index).
    pub origin: usize,
}

/// What a running stage sees: its inputs' artifacts and its files' bytes.
pub struct RunCx<'a> {
    pub(crate) inputs: Vec<Artifact>,
    pub(crate) files: &'a [PathBuf],
    pub(crate) world: &'a World,
    pub(crate) progress: &'a super::progress::Progress,
    pub(crate) warnings: std::sync::Mutex<Vec<String>>,
}

impl RunCx<'_> {
    pub fn input<T: Any + Send + Sync>(&self, i: usize) -> Arc<T> {
        self.inputs[i]
            .clone()
            .downcast::<T>()
            .unwrap_or_else(|_| panic!("input {i} has the wrong artifact type for this stage (a planner bug)"))
    }

    pub fn input_count(&self) -> usize {
        self.inputs.len()
    }

    pub fn file(&self, i: usize) -> Result<Arc<[u8]>, StageError> {
        let path = &self.files[i];
        self.world.read(path).map_err(|e| StageError::new(format!("cannot read `{}`: {e}", path.display())).in_file(i))
    }

    /// Reports something the user should know that does not stop the stage (pruned input,
    /// a fallback taken). Shown when the stage runs; part of the stage report.
    pub fn warn(&self, message: impl Into<String>) {
        if let Ok(mut w) = self.warnings.lock() {
            w.push(message.into());
        }
    }

    /// Reports progress of a long stage; shown as a bar on a terminal.
    pub fn progress(&self, done: u64, total: u64) {
        self.progress.update(done, total);
    }
}

/// A DAG of stages. Nodes are added after their inputs, so it is acyclic by construction.
#[derive(Default)]
pub struct Graph {
    pub nodes: Vec<Node>,
}

impl Graph {
    pub fn add(&mut self, node: Node) -> NodeId {
        assert!(node.inputs.iter().all(|&i| i < self.nodes.len()), "inputs must be added first");
        self.nodes.push(node);
        self.nodes.len() - 1
    }

    /// All nodes that `targets` depend on (including themselves), in ascending order.
    pub fn closure(&self, targets: &[NodeId]) -> Vec<NodeId> {
        let mut keep = vec![false; self.nodes.len()];
        let mut stack: Vec<NodeId> = targets.to_vec();
        while let Some(n) = stack.pop() {
            if !keep[n] {
                keep[n] = true;
                stack.extend(&self.nodes[n].inputs);
            }
        }
        (0..self.nodes.len()).filter(|&i| keep[i]).collect()
    }
}
