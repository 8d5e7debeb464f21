//! The base part of the thesis' split (Ch. 3.4–3.5): computations every string mechanism
//! shares. Everything here is allocation-free per call and safe to run on the real-time
//! thread.
//!
//! - [`geometry`]: string lengths, directions and the string matrix W at a pose;
//! - [`pose`]: grip pose from string lengths (damped Gauss–Newton, warm-started);
//! - [`tension`]: string tensions for a wrench (the box QP of eq. 3.16);
//! - [`box_qp`]: the exact active-set solver behind it;
//! - [`closure`]: the complete-presentation (force-closure) test;
//! - [`calibration`]: encoder counts to lengths and the calibration offsets;
//! - [`linalg`]: fixed-size LDLᵀ factorisation.

// Small dense kernels read best with the indices of their formulas.
#![allow(clippy::needless_range_loop)]

pub mod box_qp;
pub mod calibration;
pub mod closure;
pub mod geometry;
pub mod linalg;
pub mod pose;
pub mod tension;
