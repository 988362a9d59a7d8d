//! The fit: the search space, the objective (paper Eq. 7), the equation-error start, the
//! Farmland Fertility Optimizer (paper Eq. 8-16), the Levenberg-Marquardt refinement, the
//! identifiability analysis and the pipelines that chain them.
//!
//! Owns the numbers of an identification. Uses [`crate::model`]; it may not use the wire
//! format or the board application.

pub mod ffo;
pub mod identifiability;
pub mod identify;
pub mod initial;
pub mod linalg;
pub mod normal_equations;
pub mod objective;
pub mod pipeline;
pub mod profile_check;
pub mod progress;
pub mod refine;
pub mod scale_resolution;
pub mod score_blocks;
pub mod space;
pub mod sums;
pub mod torque_scale;
pub mod workspace;
