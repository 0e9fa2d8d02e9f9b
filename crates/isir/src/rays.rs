//! Ray and hit files (`docs/RAYS.md`, v1), shared with other engines, and the ray sets
//! of a scene: `primary`, `diffuse`, `shadow`.

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::ray::Ray;
use crate::sampling::{pixel_rng, square_to_cosine_hemisphere};
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::io::Write;
use std::path::Path;

const RAYS_MAGIC: &[u8; 8] = b"ISIRRAYS";
const HITS_MAGIC: &[u8; 8] = b"ISIRHITS";
const HEADER: usize = 24;

/// One ray record: the first 32 bytes of Embree's `RTCRay`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayRecord {
    /// Origin.
    pub origin: Vec3,
    /// Start of the interval.
    pub t_min: f32,
    /// Direction (not necessarily normalized).
    pub direction: Vec3,
    /// End of the interval (may be +∞).
    pub t_max: f32,
}

impl RayRecord {
    /// The ray.
    #[must_use]
    pub fn ray(&self) -> Ray {
        Ray::new(self.origin, self.direction)
    }
}

/// One hit record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HitRecord {
    /// Distance; +∞ for a miss (for occlusion: 0 when occluded).
    pub t: f32,
    /// Triangle; `u32::MAX` for a miss.
    pub prim: u32,
    /// Barycentric weight of the second vertex.
    pub u: f32,
    /// Barycentric weight of the third vertex.
    pub v: f32,
}

impl From<crate::geometry::MeshHit> for HitRecord {
    fn from(m: crate::geometry::MeshHit) -> Self {
        HitRecord { t: m.t, prim: m.prim, u: m.u, v: m.v }
    }
}

impl HitRecord {
    /// A miss.
    pub const MISS: HitRecord = HitRecord { t: f32::INFINITY, prim: u32::MAX, u: 0.0, v: 0.0 };
    /// An occluded any-hit result.
    pub const OCCLUDED: HitRecord = HitRecord { t: 0.0, prim: u32::MAX, u: 0.0, v: 0.0 };

    /// True unless a miss.
    #[must_use]
    pub fn is_hit(&self) -> bool {
        self.t < f32::INFINITY
    }
}

fn header(magic: &[u8; 8], count: usize) -> Vec<u8> {
    let mut h = Vec::with_capacity(HEADER);
    h.extend_from_slice(magic);
    h.extend_from_slice(&1u32.to_le_bytes());
    h.extend_from_slice(&0u32.to_le_bytes());
    h.extend_from_slice(&(count as u64).to_le_bytes());
    h
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
    f.write_all(bytes).map_err(io)?;
    f.flush().map_err(io)
}

fn read_records<'a>(path: &Path, bytes: &'a [u8], magic: &[u8; 8], record: usize) -> Result<&'a [u8]> {
    let bad = |message: String| Error::RayFile { path: path.to_path_buf(), message };
    if bytes.len() < HEADER || &bytes[..8] != magic {
        return Err(bad(format!("not a {} file (magic)", String::from_utf8_lossy(magic))));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
    if version != 1 {
        return Err(bad(format!("version {version} (only 1 is known)")));
    }
    let count = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
    let body = &bytes[HEADER..];
    if (body.len() as u64) < count.saturating_mul(record as u64) {
        return Err(bad(format!("header says {count} records, the file holds {}", body.len() / record)));
    }
    Ok(&body[..count as usize * record])
}

fn f32_at(b: &[u8], i: usize) -> f32 {
    f32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap())
}

/// Write a ray file.
///
/// # Errors
/// The file cannot be written.
pub fn write_rays(path: &Path, rays: &[RayRecord]) -> Result<()> {
    let mut b = header(RAYS_MAGIC, rays.len());
    b.reserve(rays.len() * 32);
    for r in rays {
        for x in [r.origin.x, r.origin.y, r.origin.z, r.t_min, r.direction.x, r.direction.y, r.direction.z, r.t_max] {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    write_file(path, &b)
}

/// Read a ray file.
///
/// # Errors
/// The file cannot be read, or is not a v1 ray file, or is truncated.
pub fn read_rays(path: &Path) -> Result<Vec<RayRecord>> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    let body = read_records(path, &bytes, RAYS_MAGIC, 32)?;
    Ok(body
        .chunks_exact(32)
        .map(|c| RayRecord {
            origin: Vec3::new(f32_at(c, 0), f32_at(c, 1), f32_at(c, 2)),
            t_min: f32_at(c, 3),
            direction: Vec3::new(f32_at(c, 4), f32_at(c, 5), f32_at(c, 6)),
            t_max: f32_at(c, 7),
        })
        .collect())
}

/// Write a hit file.
///
/// # Errors
/// The file cannot be written.
pub fn write_hits(path: &Path, hits: &[HitRecord]) -> Result<()> {
    let mut b = header(HITS_MAGIC, hits.len());
    b.reserve(hits.len() * 16);
    for h in hits {
        b.extend_from_slice(&h.t.to_le_bytes());
        b.extend_from_slice(&h.prim.to_le_bytes());
        b.extend_from_slice(&h.u.to_le_bytes());
        b.extend_from_slice(&h.v.to_le_bytes());
    }
    write_file(path, &b)
}

/// Read a hit file.
///
/// # Errors
/// The file cannot be read, or is not a v1 hit file, or is truncated.
pub fn read_hits(path: &Path) -> Result<Vec<HitRecord>> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    let body = read_records(path, &bytes, HITS_MAGIC, 16)?;
    Ok(body
        .chunks_exact(16)
        .map(|c| HitRecord { t: f32_at(c, 0), prim: u32::from_le_bytes(c[4..8].try_into().unwrap()), u: f32_at(c, 2), v: f32_at(c, 3) })
        .collect())
}

/// The kinds of ray sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// One ray through the centre of every pixel, row by row from the top-left.
    Primary,
    /// From each primary hit, a cosine-distributed direction about the geometric normal
    /// (facing the camera), origin offset along it; misses dropped.
    Diffuse,
    /// From each primary hit towards a random point of the scene's first light, `t_max`
    /// just short of it; misses dropped.
    Shadow,
}

impl RayKind {
    /// Every kind.
    pub const ALL: [RayKind; 3] = [RayKind::Primary, RayKind::Diffuse, RayKind::Shadow];

    /// The command-line name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Diffuse => "diffuse",
            RayKind::Shadow => "shadow",
        }
    }
}

impl std::str::FromStr for RayKind {
    type Err = String;
    /// Parse `primary`, `diffuse` or `shadow`.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        crate::parse_name(s, &Self::ALL, Self::name, "ray set")
    }
}

/// The ray set of a scene seen by `camera` at `width × height`. Deterministic for a seed.
///
/// # Errors
/// Shadow rays of a scene without lights.
pub fn generate(scene: &Scene, camera: &Camera, width: u32, height: u32, kind: RayKind, seed: u64) -> Result<Vec<RayRecord>> {
    if kind == RayKind::Shadow && scene.lights.is_empty() {
        return Err(Error::Scene("shadow rays need a light, and this scene has none".into()));
    }
    let rows: Vec<Vec<RayRecord>> = (0..height)
        .into_par_iter()
        .map(|y| {
            let mut out = Vec::with_capacity(width as usize);
            for x in 0..width {
                let primary = camera.generate_ray((x as f32 + 0.5) / width as f32, (y as f32 + 0.5) / height as f32);
                if kind == RayKind::Primary {
                    out.push(RayRecord { origin: primary.origin, t_min: 0.0, direction: primary.direction, t_max: f32::INFINITY });
                    continue;
                }
                let Some(hit) = scene.intersect(&primary, 0.0, f32::INFINITY) else {
                    continue;
                };
                let mut rng = pixel_rng(seed, u64::from(y) * u64::from(width) + u64::from(x), 0);
                let n = hit.geometric_normal;
                match kind {
                    RayKind::Diffuse => {
                        let d = square_to_cosine_hemisphere(n, rng.next_2d());
                        let r = hit.spawn_ray(d);
                        out.push(RayRecord { origin: r.origin, t_min: 0.0, direction: d, t_max: f32::INFINITY });
                    }
                    RayKind::Shadow => {
                        let ls = scene.lights[0].sample(hit.point, rng.next_2d());
                        // The renderer's own shadow ray.
                        if let Some((r, t_max)) = hit.spawn_ray_to(ls.point) {
                            out.push(RayRecord { origin: r.origin, t_min: 0.0, direction: r.direction, t_max });
                        }
                    }
                    RayKind::Primary => unreachable!(),
                }
            }
            out
        })
        .collect();
    Ok(rows.into_iter().flatten().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_round_trip_and_reject_garbage() {
        let dir = std::env::temp_dir().join(format!("isir-rays-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let rays = vec![
            RayRecord { origin: Vec3::new(1.0, 2.0, 3.0), t_min: 0.0, direction: Vec3::new(0.0, 0.0, 1.0), t_max: f32::INFINITY },
            RayRecord { origin: Vec3::ZERO, t_min: 0.5, direction: Vec3::new(1.0, -1.0, 0.0), t_max: 9.0 },
        ];
        let p = dir.join("r.bin");
        write_rays(&p, &rays).unwrap();
        assert_eq!(std::fs::metadata(&p).unwrap().len(), 24 + 64);
        assert_eq!(read_rays(&p).unwrap(), rays);
        let hits = vec![HitRecord::MISS, HitRecord { t: 2.0, prim: 7, u: 0.25, v: 0.5 }];
        let h = dir.join("h.bin");
        write_hits(&h, &hits).unwrap();
        assert_eq!(read_hits(&h).unwrap(), hits);
        // Wrong magic, truncated body.
        assert!(read_rays(&h).unwrap_err().to_string().contains("magic"));
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 5]).unwrap();
        assert!(read_rays(&p).unwrap_err().to_string().contains("header says 2"));
        std::fs::remove_dir_all(&dir).ok();
    }
}

// ---- Tracing ray sets ----

/// Rays per parallel work item when tracing a ray set (Embree's bench uses 1024 too).
const CHUNK: usize = 1024;

/// Trace every ray of a set against a mesh on the current rayon pool, writing one record
/// per ray into `hits` (closest hits, or with `occluded` the any-hit result).
///
/// # Panics
/// If `hits` and `rays` differ in length.
pub fn trace_mesh(mesh: &crate::TriangleMesh, rays: &[RayRecord], occluded: bool, hits: &mut [HitRecord]) {
    assert_eq!(rays.len(), hits.len());
    rays.par_chunks(CHUNK).zip(hits.par_chunks_mut(CHUNK)).for_each(|(rays, hits)| {
        for (r, h) in rays.iter().zip(hits) {
            let ray = r.ray();
            *h = if occluded {
                if mesh.occluded(&ray, r.t_min, r.t_max) {
                    HitRecord::OCCLUDED
                } else {
                    HitRecord::MISS
                }
            } else {
                mesh.intersect(&ray, r.t_min, r.t_max).map_or(HitRecord::MISS, HitRecord::from)
            };
        }
    });
}

/// [`trace_mesh`] for closest hits of coherent rays: consecutive rays go in packets of
/// 16 through [`crate::wide::WideBvh::intersect_packet`] when the mesh has a wide BVH
/// (one at a time otherwise). Same hits as [`trace_mesh`].
///
/// # Panics
/// If `hits` and `rays` differ in length.
pub fn trace_mesh_packets(mesh: &crate::TriangleMesh, rays: &[RayRecord], hits: &mut [HitRecord]) {
    use crate::geometry::MeshAccel;
    use crate::packet::PACKET;
    let MeshAccel::Wide(wide) = mesh.accel() else {
        return trace_mesh(mesh, rays, false, hits);
    };
    assert_eq!(rays.len(), hits.len());
    rays.par_chunks(CHUNK).zip(hits.par_chunks_mut(CHUNK)).for_each(|(rays, hits)| {
        let mut out = [None; PACKET];
        for (rays, hits) in rays.chunks(PACKET).zip(hits.chunks_mut(PACKET)) {
            wide.intersect_packet(rays, &mut out);
            for (h, o) in hits.iter_mut().zip(&out) {
                *h = o.map_or(HitRecord::MISS, HitRecord::from);
            }
        }
    });
}

/// How two hit sets of the same rays agree.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HitAgreement {
    /// Rays compared.
    pub rays: usize,
    /// Rays with the same hit/miss and `t` within the relative tolerance.
    pub agree: usize,
    /// Rays hit by both.
    pub both_hit: usize,
}

impl HitAgreement {
    /// Fraction of rays that agree.
    #[must_use]
    pub fn fraction(&self) -> f64 {
        if self.rays == 0 {
            1.0
        } else {
            self.agree as f64 / self.rays as f64
        }
    }
}

/// Compare two hit sets: same hit/miss and `|t_a - t_b| <= rel_tol · max(|t_a|, |t_b|)`.
#[must_use]
pub fn compare_hits(a: &[HitRecord], b: &[HitRecord], rel_tol: f32) -> HitAgreement {
    let mut r = HitAgreement { rays: a.len().min(b.len()), ..Default::default() };
    for (x, y) in a.iter().zip(b) {
        match (x.is_hit(), y.is_hit()) {
            (false, false) => r.agree += 1,
            (true, true) => {
                r.both_hit += 1;
                if (x.t - y.t).abs() <= rel_tol * x.t.abs().max(y.t.abs()) {
                    r.agree += 1;
                }
            }
            _ => {}
        }
    }
    r
}
