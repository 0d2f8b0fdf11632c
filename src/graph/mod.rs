//! Keys, cache and scheduling. Knows nothing of the scene language or the algorithms:
//! stages are opaque boxes with a kind, a version, parameters, inputs and files.
pub mod budget;
pub mod cache;
pub mod exec;
pub mod files;
pub mod key;
pub mod progress;
pub mod remote;
pub mod stage;
pub mod stats;
pub mod watch;
pub mod world;

pub use budget::Budget;
pub use cache::Cache;
pub use exec::{Executor, Failure, MemoryCache, Outcome, Report, StageRecord, Status};
pub use files::write_atomic;
pub use key::Key;
pub use stage::{AnyHandle, Artifact, Graph, Handle, In, Inputs, Node, NodeId, RunCx, Stage, StageError, Typed};
pub use world::World;
