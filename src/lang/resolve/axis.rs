//! Which side of a declaration's extent a relative length is a part of, as the value being
//! checked implies it (the checker sets it, arithmetic reads it).

/// Which side of the extent a relative length (`40%`) is a part of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Axis {
    /// A length with no axis (a radius, a block): the shorter side.
    Short,
    /// The first component of a point or size: the width.
    X,
    /// The second: the height.
    Y,
}
