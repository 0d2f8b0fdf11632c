//! The unit of cached work.

use std::any::{Any, TypeId};
use std::marker::PhantomData;
use std::path::PathBuf;
use std::sync::Arc;

use super::budget::Budget;
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
    /// Which property of the declaration, if the failure is about one (`block.name` for one
    /// inside a block; the diagnostic points at the nearest of them the user wrote).
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

/// A stage whose artifact type is known where it is wired, so that [`Graph::add_typed`] can
/// hand back a [`Handle`] of that type.
pub trait Typed: Stage {
    type Output: Any + Send + Sync;
}

/// A node whose artifact is a `T`. Only [`Graph::add_typed`] (from the stage's own type)
/// and [`AnyHandle::typed`] (checking the type) make one, so a stage that reads a handle
/// reads the type its producer makes.
pub struct Handle<T> {
    node: NodeId,
    ty: PhantomData<fn() -> T>,
}

impl<T> Clone for Handle<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Handle<T> {}

impl<T: Any> Handle<T> {
    pub fn node(self) -> NodeId {
        self.node
    }

    /// The handle with its type kept for a check at [`AnyHandle::typed`]: a declaration's
    /// result, stored by name beside results of other types.
    pub fn erase(self) -> AnyHandle {
        AnyHandle { node: self.node, ty: TypeId::of::<T>(), ty_name: std::any::type_name::<T>() }
    }
}

/// A [`Handle`] whose artifact type is checked when it is used, not when it is stored.
#[derive(Clone, Copy, Debug)]
pub struct AnyHandle {
    node: NodeId,
    ty: TypeId,
    ty_name: &'static str,
}

impl AnyHandle {
    pub fn node(self) -> NodeId {
        self.node
    }

    /// The handle as a `T`, if its node makes a `T`.
    pub fn typed<T: Any>(self) -> Option<Handle<T>> {
        (self.ty == TypeId::of::<T>()).then_some(Handle { node: self.node, ty: PhantomData })
    }

    /// The artifact type's name, for messages about a planner that wired the wrong type.
    pub fn type_name(self) -> &'static str {
        self.ty_name
    }
}

/// One input of a stage: the artifact of type `T` at a position of the stage's input list,
/// read with [`RunCx::get`]. It serialises as that position, so a stage keyed by a value
/// holding its inputs keys its wiring too.
pub struct In<T> {
    index: u32,
    ty: PhantomData<fn() -> T>,
}

impl<T> Clone for In<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for In<T> {}

impl<T> std::fmt::Debug for In<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "In({})", self.index)
    }
}

impl<T> serde::Serialize for In<T> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u32(self.index)
    }
}

/// The input list of a stage being wired: each [`Inputs::add`] hands back the [`In`] the
/// stage's work reads it through.
#[derive(Default)]
pub struct Inputs {
    nodes: Vec<NodeId>,
}

impl Inputs {
    pub fn new() -> Self {
        Inputs::default()
    }

    pub fn add<T>(&mut self, h: Handle<T>) -> In<T> {
        let index = u32::try_from(self.nodes.len()).expect("fewer than 2³² inputs");
        self.nodes.push(h.node);
        In { index, ty: PhantomData }
    }

    /// Each handle of `hs`, in order.
    pub fn add_all<T>(&mut self, hs: impl IntoIterator<Item = Handle<T>>) -> Vec<In<T>> {
        hs.into_iter().map(|h| self.add(h)).collect()
    }

    pub fn nodes(&self) -> &[NodeId] {
        &self.nodes
    }
}

/// What a running stage sees: its inputs' artifacts, its files' bytes and the memory budget.
pub struct RunCx<'a> {
    pub(crate) inputs: Vec<Artifact>,
    pub(crate) files: &'a [PathBuf],
    pub(crate) world: &'a World,
    pub(crate) budget: Budget,
    pub(crate) progress: &'a super::progress::Progress,
    pub(crate) warnings: std::sync::Mutex<Vec<String>>,
}

impl RunCx<'_> {
    /// The artifact of input `i`. Its type is the producer's, by construction of [`In`].
    pub fn get<T: Any + Send + Sync>(&self, i: In<T>) -> Arc<T> {
        self.inputs[i.index as usize].clone().downcast::<T>().unwrap_or_else(|_| {
            panic!(
                "input {} is not a {} (an `In` used with another stage's inputs)",
                i.index,
                std::any::type_name::<T>()
            )
        })
    }

    /// The memory budget the build is held to. It decides whether a result is computed,
    /// never what it is, so it is no part of any key (stages read it here, not from their
    /// keyed parameters).
    pub fn budget(&self) -> Budget {
        self.budget
    }

    pub fn file(&self, i: usize) -> Result<Arc<[u8]>, StageError> {
        let path = &self.files[i];
        self.world.read(path).map_err(|e| StageError::new(format!("cannot read `{}`: {e}", path.display())).in_file(i))
    }

    /// How many input files the stage has.
    pub fn file_count(&self) -> usize {
        self.files.len()
    }

    /// The final component of input file `i`'s path, as messages name it.
    pub fn file_name(&self, i: usize) -> String {
        super::files::name_of(&self.files[i])
    }

    /// Reports something the user should know that does not stop the stage (pruned input,
    /// a fallback taken). Part of the stage report, kept with the cache entry and shown again
    /// on every build that loads or skips the stage.
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

    /// Adds a stage reading `inputs`; the handle of its artifact.
    pub fn add_typed<S: Typed + 'static>(
        &mut self,
        label: String,
        stage: S,
        inputs: Inputs,
        files: Vec<PathBuf>,
        origin: usize,
    ) -> Handle<S::Output> {
        let node = self.add(Node { label, stage: Box::new(stage), inputs: inputs.nodes, files, origin });
        Handle { node, ty: PhantomData }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A stage making a `T` from nothing, to wire graphs with.
    struct Makes<T>(PhantomData<fn() -> T>);

    impl<T: Any + Send + Sync> Stage for Makes<T> {
        fn kind(&self) -> &'static str {
            "test.makes"
        }
        fn version(&self) -> u32 {
            1
        }
        fn params(&self) -> String {
            String::new()
        }
        fn run(&self, _: &RunCx) -> Result<Artifact, StageError> {
            Err(StageError::new("not run in these tests"))
        }
        fn encode(&self, _: &Artifact) -> Vec<u8> {
            Vec::new()
        }
        fn decode(&self, _: &[u8]) -> Result<Artifact, String> {
            Err("not decoded in these tests".into())
        }
    }

    impl<T: Any + Send + Sync> Typed for Makes<T> {
        type Output = T;
    }

    fn makes<T>() -> Makes<T> {
        Makes(PhantomData)
    }

    #[test]
    fn a_stored_handle_is_typed_again_only_as_what_its_stage_makes() {
        let mut g = Graph::default();
        let number: Handle<u32> = g.add_typed("n".into(), makes::<u32>(), Inputs::new(), vec![], 0);
        let stored = number.erase();
        assert_eq!(stored.typed::<u32>().map(Handle::node), Some(number.node()));
        assert!(stored.typed::<String>().is_none());
        assert_eq!(stored.type_name(), "u32");
    }

    #[test]
    fn inputs_are_wired_in_order_and_serialise_as_their_position() {
        let mut g = Graph::default();
        let a = g.add_typed("a".into(), makes::<u32>(), Inputs::new(), vec![], 0);
        let b = g.add_typed("b".into(), makes::<String>(), Inputs::new(), vec![], 0);
        let mut inputs = Inputs::new();
        let (ib, ia) = (inputs.add(b), inputs.add(a));
        assert_eq!(inputs.nodes(), [b.node(), a.node()]);
        assert_eq!(serde_json::to_string(&(ib, ia)).unwrap(), "[0,1]");
        let c = g.add_typed("c".into(), makes::<u32>(), inputs, vec![], 0);
        assert_eq!(g.nodes[c.node()].inputs, [b.node(), a.node()]);
    }
}
