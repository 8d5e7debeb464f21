//! Soft bodies (thesis 7.2): a volume cut into tetrahedra, its nodes moved by co-rotational
//! finite elements (the linear strain taken along with each element's turn, the volume's
//! own ratio in the volume term) under an implicit step, so a stiff material stays stable at any
//! step and its energy under a still hand decays.
//!
//! - [`lattice`] cuts a box or a solid (a ball, a closed mesh) into tetrahedra at a
//!   resolution;
//! - [`element`] is what one tetrahedron contributes: its shape functions' gradients at its
//!   quadrature points, linear (4 nodes) or quadratic (10 nodes, which bends as a beam
//!   should where linear ones lock);
//! - [`rotation`] finds an element's turn, which its stiffness is taken along with;
//! - [`body`] is a soft body's nodes, elements, masses and pins;
//! - [`motion`] takes it whole: its turn, velocity and spin, an impulse or a motion given;
//! - [`implicit`] steps it: backward Euler, solved by conjugate gradients;
//! - [`factor`] is its rest system factored, which preconditions the solve, and
//!   [`capacitance`] corrects that for the nodes held on obstacles.

pub mod body;
pub mod capacitance;
pub mod contact;
pub mod element;
pub mod factor;
pub mod implicit;
pub mod lattice;
pub mod material;
pub mod motion;
pub mod rotation;
