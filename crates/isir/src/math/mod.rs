//! The mathematics under everything: rays and their floating-point error bounds
//! ([`ray`], after pbrt-v4 §6.8), boxes ([`aabb`]), linear RGB ([`color`]) and random
//! numbers with the warps that turn them into directions ([`sampling`], each warp beside
//! its pdf).

pub mod aabb;
pub mod color;
pub mod ray;
pub mod sampling;
