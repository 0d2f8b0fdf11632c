//! The search space of one shader: which entries of its flat parameter vector a search moves,
//! over which ranges, and the map between them and the unit cube the catalogue and the simplex
//! work in ([references: bourque §9]: parameter distances are measured on ranges normalised to
//! `[0, 1]`, so a brick's width and its mortar count alike).
//!
//! Integer entries are searched as reals and rounded before every render, so a search never
//! renders the degenerate in-between images of the thesis's star (Fig. 4-22).

use serde::Serialize;

use crate::synth::shader::{params, ParamError, ParamKind, ShaderDef};

/// One searched entry of the flat vector.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Axis {
    /// The parameter's name (a colour's three entries share it).
    pub name: &'static str,
    /// Its index in the flat vector.
    pub index: usize,
    pub min: f64,
    pub max: f64,
    /// Whether it takes whole numbers only.
    pub int: bool,
}

/// A shader, the values of its fixed entries and its searched axes.
#[derive(Clone, Serialize)]
pub struct Space {
    pub shader: &'static ShaderDef,
    /// The full flat vector; the searched entries are overwritten.
    pub base: Vec<f64>,
    pub axes: Vec<Axis>,
}

/// A scene's change to one parameter's search: a narrower range, or whether it is searched.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AxisOverride {
    pub name: String,
    pub search: Option<bool>,
    pub range: Option<(f64, f64)>,
}

/// Why a search space cannot be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SpaceError {
    #[error("`{shader}` has no parameter `{name}`")]
    Unknown { shader: &'static str, name: String },
    #[error("the search range [{lo}, {hi}] of `{name}` is not inside its range [{min}, {max}]")]
    Range { name: String, lo: f64, hi: f64, min: f64, max: f64 },
    #[error(transparent)]
    Param(#[from] ParamError),
}

impl Space {
    /// The shader's default search: its defaults, with the parameters its table marks as
    /// searched moving over their whole ranges.
    pub fn new(shader: &'static ShaderDef) -> Space {
        Space::with(shader, shader.defaults(), &[]).expect("a shader's defaults and ranges are valid")
    }

    /// A search from `base` (a valid flat vector) with `overrides` applied.
    pub fn with(shader: &'static ShaderDef, base: Vec<f64>, overrides: &[AxisOverride]) -> Result<Space, SpaceError> {
        params::validate(shader.params, &base)?;
        for o in overrides {
            if shader.param(&o.name).is_none() {
                return Err(SpaceError::Unknown { shader: shader.name, name: o.name.clone() });
            }
        }
        let mut axes = Vec::new();
        for (p, at) in shader.params.iter().zip(params::offsets(shader.params)) {
            let o = overrides.iter().find(|o| o.name == p.name);
            if !o.and_then(|o| o.search).unwrap_or(p.search || o.is_some_and(|o| o.range.is_some())) {
                continue;
            }
            let (min, max) = p.kind.bounds();
            let (lo, hi) = o.and_then(|o| o.range).unwrap_or((min, max));
            if !(min <= lo && lo <= hi && hi <= max) {
                return Err(SpaceError::Range { name: p.name.to_string(), lo, hi, min, max });
            }
            let int = matches!(p.kind, ParamKind::Int { .. });
            let (lo, hi) = if int { (lo.ceil(), hi.floor()) } else { (lo, hi) };
            if lo > hi {
                return Err(SpaceError::Range { name: p.name.to_string(), lo, hi, min, max });
            }
            for k in 0..p.kind.width() {
                axes.push(Axis { name: p.name, index: at + k, min: lo, max: hi, int });
            }
        }
        Ok(Space { shader, base, axes })
    }

    pub fn dim(&self) -> usize {
        self.axes.len()
    }

    /// The flat parameter vector at a point of the unit cube (clamped into it, whole numbers
    /// rounded).
    pub fn values(&self, x: &[f64]) -> Vec<f64> {
        let mut v = self.base.clone();
        for (a, &t) in self.axes.iter().zip(x) {
            let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
            let value = a.min + t * (a.max - a.min);
            v[a.index] = if a.int { value.round() } else { value }.clamp(a.min, a.max);
        }
        v
    }

    /// The point of the unit cube of a flat vector's searched entries.
    pub fn normalise(&self, values: &[f64]) -> Vec<f64> {
        self.axes
            .iter()
            .map(|a| if a.max > a.min { ((values[a.index] - a.min) / (a.max - a.min)).clamp(0.0, 1.0) } else { 0.0 })
            .collect()
    }

    /// Moves `x` onto the nearest point a render can show: inside the cube, whole numbers whole.
    pub fn snap(&self, x: &mut [f64]) {
        let v = self.values(x);
        x.copy_from_slice(&self.normalise(&v));
    }

    /// The smallest step along each axis that changes the render: one whole number for
    /// integer axes, none for the others.
    pub fn quantum(&self, axis: usize) -> f64 {
        let a = &self.axes[axis];
        if a.int && a.max > a.min {
            1.0 / (a.max - a.min)
        } else {
            0.0
        }
    }
}
