//! Linear RGB colours and the course's named colours.

use glam::Vec3;

/// A linear RGB colour (floats, not clamped).
pub type Color = Vec3;

/// Black.
pub const BLACK: Color = Vec3::new(0.0, 0.0, 0.0);
/// White.
pub const WHITE: Color = Vec3::new(1.0, 1.0, 1.0);
/// The course's grey, 0.5; also the background colour.
pub const GREY: Color = Vec3::new(0.5, 0.5, 0.5);
/// Red.
pub const RED: Color = Vec3::new(1.0, 0.0, 0.0);
/// Green.
pub const GREEN: Color = Vec3::new(0.0, 1.0, 0.0);
/// Blue.
pub const BLUE: Color = Vec3::new(0.0, 0.0, 1.0);
/// Yellow.
pub const YELLOW: Color = Vec3::new(1.0, 1.0, 0.0);
/// Magenta.
pub const MAGENTA: Color = Vec3::new(1.0, 0.0, 1.0);
/// Cyan.
pub const CYAN: Color = Vec3::new(0.0, 1.0, 1.0);
