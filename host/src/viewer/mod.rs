//! The testable logic of the interactive viewer `gi view` (the window and its event loop are in
//! the `gi` program): the [`fly_camera`], the [`bindings`] of keys to actions and technique
//! toggles, the [`overlay`] text drawn on the CPU, and the [`framebuffer`] conversions between our
//! images and the window's pixels.

pub mod bindings;
pub mod fly_camera;
pub mod framebuffer;
pub mod overlay;

pub use bindings::{Action, Toggle};
pub use fly_camera::{FlyCamera, Movement};
pub use overlay::Overlay;
