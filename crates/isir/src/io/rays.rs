//! Ray and hit files (`docs/RAYS.md`, v1), shared with other engines, and the ray sets
//! of a scene: `primary`, `diffuse`, `shadow`.

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::math::aabb::Aabb;
use crate::math::ray::RaySegment;
use crate::math::sampling::{pixel_rng, square_to_cosine_hemisphere, square_to_uniform_sphere};
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::io::{Read, Seek, Write};
use std::path::Path;

const RAYS_MAGIC: &[u8; 8] = b"ISIRRAYS";
const HITS_MAGIC: &[u8; 8] = b"ISIRHITS";
const HEADER: usize = 24;

/// One ray record: the first 32 bytes of Embree's `RTCRay`, which is exactly a
/// [`RaySegment`] (a ray and its interval), the type the packet tracer takes.
pub type RayRecord = RaySegment;

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

fn header(magic: &[u8; 8], count: usize) -> [u8; HEADER] {
    let mut h = [0; HEADER];
    h[..8].copy_from_slice(magic);
    h[8..12].copy_from_slice(&1u32.to_le_bytes());
    h[16..24].copy_from_slice(&(count as u64).to_le_bytes());
    h
}

/// Write a ray or hit file whole or not at all ([`crate::io::output`]), record by record:
/// no copy of the records in memory.
fn write_records<T>(path: &Path, magic: &[u8; 8], records: &[T], encode: impl Fn(&T, &mut Vec<u8>)) -> Result<()> {
    crate::io::output::write_atomically(path, |w| {
        w.write_all(&header(magic, records.len()))?;
        let mut b = Vec::with_capacity(32);
        for r in records {
            b.clear();
            encode(r, &mut b);
            w.write_all(&b)?;
        }
        Ok(())
    })
}

/// Records read at a time.
const READ_CHUNK: usize = 1 << 16;

/// Read the records of a ray or hit file. The header's count is checked against the
/// file's size before anything is allocated for the records: a file is read for what it
/// holds, not for what it claims, and trailing bytes are an error too.
fn read_records<T>(path: &Path, magic: &[u8; 8], record: usize, decode: impl Fn(&[u8]) -> T) -> Result<Vec<T>> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let bad = |message: String| Error::RayFile { path: path.to_path_buf(), message };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        // A FIFO or a device has no size to check the header against (and may never end).
        return Err(bad("not a regular file".into()));
    }
    let mut f = std::fs::File::open(path).map_err(io)?;
    let mut h = [0u8; HEADER];
    let mut got = 0;
    while got < HEADER {
        match f.read(&mut h[got..]).map_err(io)? {
            0 => break,
            n => got += n,
        }
    }
    if (8..HEADER).contains(&got) && &h[..8] == magic {
        return Err(bad(format!("{got} bytes: shorter than the {HEADER}-byte header")));
    }
    if got < HEADER || &h[..8] != magic {
        let (want, other) = if magic == RAYS_MAGIC { ("ray", ("hit", HITS_MAGIC)) } else { ("hit", ("ray", RAYS_MAGIC)) };
        let what = if got >= 8 && &h[..8] == other.1 {
            format!("a {} file, not a {want} file", other.0)
        } else {
            format!("not a {want} file (it does not start with {}, docs/RAYS.md)", String::from_utf8_lossy(magic))
        };
        return Err(bad(what));
    }
    let version = u32::from_le_bytes(h[8..12].try_into().unwrap());
    if version != 1 {
        return Err(bad(format!("version {version} (only 1 is known)")));
    }
    let count = u64::from_le_bytes(h[16..24].try_into().unwrap());
    let body = meta.len().saturating_sub(HEADER as u64); // (the file may have grown since)
    let size = count.checked_mul(record as u64);
    if size != Some(body) {
        let (whole, rest) = (body / record as u64, body % record as u64);
        let extra = if rest == 0 { String::new() } else { format!(" and {rest} bytes") };
        let claimed = size.map_or_else(|| "more than 2^64".to_string(), |s| s.to_string());
        let records = |n: u64| if n == 1 { "1 record".to_string() } else { format!("{n} records") };
        return Err(bad(format!(
            "header says {} ({claimed} bytes), the file holds {body} bytes after the header ({}{extra})",
            records(count),
            records(whole)
        )));
    }
    let count = usize::try_from(count).map_err(|_| bad(format!("{count} records do not fit in memory")))?;
    let mut out = Vec::with_capacity(count);
    let mut buf = vec![0u8; READ_CHUNK.min(count.max(1)) * record];
    let mut f = std::io::BufReader::new(f);
    while out.len() < count {
        let n = (count - out.len()).min(READ_CHUNK);
        let chunk = &mut buf[..n * record];
        f.read_exact(chunk).map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                bad(format!("header says {count} records, the file ended after {} (it changed while read)", out.len()))
            } else {
                io(e)
            }
        })?;
        out.extend(chunk.chunks_exact(record).map(&decode));
    }
    if f.read(&mut [0u8; 1]).map_err(io)? != 0 {
        return Err(bad(format!("header says {count} records, the file holds more (it changed while read)")));
    }
    Ok(out)
}

fn f32_at(b: &[u8], i: usize) -> f32 {
    f32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap())
}

fn encode_ray(r: &RayRecord, b: &mut Vec<u8>) {
    for x in [r.origin.x, r.origin.y, r.origin.z, r.t_min, r.direction.x, r.direction.y, r.direction.z, r.t_max] {
        b.extend_from_slice(&x.to_le_bytes());
    }
}

/// Write a ray file, whole or not at all.
///
/// # Errors
/// The file cannot be written; the file that was there is then left intact.
pub fn write_rays(path: &Path, rays: &[RayRecord]) -> Result<()> {
    write_records(path, RAYS_MAGIC, rays, encode_ray)
}

/// Read a ray file.
///
/// # Errors
/// The file cannot be read, or is not a v1 ray file, or its size disagrees with its
/// header's count (truncated, or trailing bytes).
pub fn read_rays(path: &Path) -> Result<Vec<RayRecord>> {
    read_records(path, RAYS_MAGIC, 32, |c| RayRecord {
        origin: Vec3::new(f32_at(c, 0), f32_at(c, 1), f32_at(c, 2)),
        t_min: f32_at(c, 3),
        direction: Vec3::new(f32_at(c, 4), f32_at(c, 5), f32_at(c, 6)),
        t_max: f32_at(c, 7),
    })
}

/// Write a hit file, whole or not at all.
///
/// # Errors
/// The file cannot be written; the file that was there is then left intact.
pub fn write_hits(path: &Path, hits: &[HitRecord]) -> Result<()> {
    write_records(path, HITS_MAGIC, hits, |h, b| {
        b.extend_from_slice(&h.t.to_le_bytes());
        b.extend_from_slice(&h.prim.to_le_bytes());
        b.extend_from_slice(&h.u.to_le_bytes());
        b.extend_from_slice(&h.v.to_le_bytes());
    })
}

/// Read a hit file.
///
/// # Errors
/// The file cannot be read, or is not a v1 hit file, or its size disagrees with its
/// header's count (truncated, or trailing bytes).
pub fn read_hits(path: &Path) -> Result<Vec<HitRecord>> {
    read_records(path, HITS_MAGIC, 16, |c| HitRecord {
        t: f32_at(c, 0),
        prim: u32::from_le_bytes(c[4..8].try_into().unwrap()),
        u: f32_at(c, 2),
        v: f32_at(c, 3),
    })
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
    /// One ray per pixel from a uniformly random point of the box of the scene's bounded
    /// objects in a uniformly random direction, closest hit: no coherence at all (the
    /// camera only sets how many).
    Random,
}

impl RayKind {
    /// Every kind.
    pub const ALL: [RayKind; 4] = [RayKind::Primary, RayKind::Diffuse, RayKind::Shadow, RayKind::Random];

    /// The command-line name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Diffuse => "diffuse",
            RayKind::Shadow => "shadow",
            RayKind::Random => "random",
        }
    }
}

impl std::str::FromStr for RayKind {
    type Err = String;
    /// Parse `primary`, `diffuse`, `shadow` or `random`.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        crate::parse_name(s, &Self::ALL, Self::name, "ray set")
    }
}

/// The ray set of a scene seen by `camera` at `width × height`. Deterministic for a seed.
///
/// # Errors
/// Shadow rays of a scene without lights; more rays than an image may have pixels
/// ([`crate::io::image::check_size`]: 32 bytes a ray held at once; [`write_ray_set`]
/// streams larger sets to a file).
pub fn generate(scene: &Scene, camera: &Camera, width: u32, height: u32, kind: RayKind, seed: u64) -> Result<Vec<RayRecord>> {
    crate::io::image::check_size(width, height)?;
    check_kind(scene, kind)?;
    Ok(generate_rows(scene, camera, width, height, kind, seed, 0..height))
}

/// Rays generated at a time by [`write_ray_set`]: about 2^20, whole rows.
const BAND_RAYS: u32 = 1 << 20;

/// Generate the ray set of [`generate`] and write it to a ray file as it is generated, a
/// band of rows (about 2^20 rays, 32 MiB) at a time: the memory it takes is bounded by the
/// band whatever the image size (the file holds 32 bytes per ray: 8 GiB at
/// [`crate::io::image::MAX_PIXELS`]). The file is the one [`write_rays`] writes of
/// [`generate`]'s set, written whole or not at all. Returns the number of rays.
///
/// # Errors
/// Shadow rays of a scene without lights; the file cannot be written (the file that was
/// there is then left intact).
pub fn write_ray_set(path: &Path, scene: &Scene, camera: &Camera, width: u32, height: u32, kind: RayKind, seed: u64) -> Result<usize> {
    write_ray_set_in_bands(path, scene, camera, [width, height], kind, seed, (BAND_RAYS / width.max(1)).max(1))
}

fn write_ray_set_in_bands(
    path: &Path,
    scene: &Scene,
    camera: &Camera,
    [width, height]: [u32; 2],
    kind: RayKind,
    seed: u64,
    band: u32,
) -> Result<usize> {
    check_kind(scene, kind)?;
    let mut count = 0;
    crate::io::output::write_atomically(path, |w| {
        // The count of diffuse and shadow rays is known at the end: written then.
        w.write_all(&header(RAYS_MAGIC, 0))?;
        let mut b = Vec::with_capacity(32);
        for y0 in (0..height).step_by(band as usize) {
            for r in generate_rows(scene, camera, width, height, kind, seed, y0..(y0.saturating_add(band)).min(height)) {
                b.clear();
                encode_ray(&r, &mut b);
                w.write_all(&b)?;
                count += 1;
            }
        }
        w.seek(std::io::SeekFrom::Start(16))?;
        w.write_all(&(count as u64).to_le_bytes())
    })?;
    Ok(count)
}

fn check_kind(scene: &Scene, kind: RayKind) -> Result<()> {
    if kind == RayKind::Shadow && scene.lights.is_empty() {
        return Err(Error::Scene("shadow rays need a light, and this scene has none".into()));
    }
    if kind == RayKind::Random && scene_box(scene).is_none() {
        return Err(Error::Scene("random rays start inside the box of the scene's bounded objects, and this scene has none".into()));
    }
    Ok(())
}

/// The box of the scene's bounded objects (planes have none), if it is not empty.
fn scene_box(scene: &Scene) -> Option<Aabb> {
    let b = (0..scene.objects.len()).filter_map(|i| scene.object_bounds(i)).fold(Aabb::EMPTY, |b, o| b.union(&o));
    b.is_finite_nonempty().then_some(b)
}

/// The rays of the rows `rows` of the set, row by row from the top-left, in parallel.
fn generate_rows(
    scene: &Scene,
    camera: &Camera,
    width: u32,
    height: u32,
    kind: RayKind,
    seed: u64,
    rows: std::ops::Range<u32>,
) -> Vec<RayRecord> {
    let bounds = if kind == RayKind::Random { scene_box(scene) } else { None };
    rows.into_par_iter()
        .flat_map_iter(|y| {
            let mut out = Vec::with_capacity(width as usize);
            for x in 0..width {
                if let Some(b) = bounds {
                    let mut rng = pixel_rng(seed, u64::from(y) * u64::from(width) + u64::from(x), 0);
                    let (a, c) = (rng.next_2d(), rng.next_f32());
                    let origin = b.min + (b.max - b.min) * Vec3::new(a.x, a.y, c);
                    let direction = square_to_uniform_sphere(rng.next_2d());
                    out.push(RayRecord { origin, t_min: 0.0, direction, t_max: f32::INFINITY });
                    continue;
                }
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
                    RayKind::Primary | RayKind::Random => unreachable!(),
                }
            }
            out
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Random rays: one per pixel, from inside the box of the bounded objects, unit
    /// directions spread over the whole sphere, the same set for the same seed; a scene of
    /// planes alone has no box and is refused.
    #[test]
    fn random_rays_fill_the_scene_box_in_every_direction() {
        let desc = crate::scenes::builtin("tp4-bunny").unwrap();
        let scene = desc.build(crate::Accel::BvhSah).unwrap();
        let camera = desc.camera.build(1.5);
        let rays = generate(&scene, &camera, 40, 30, RayKind::Random, 7).unwrap();
        assert_eq!(rays.len(), 1200);
        let b = scene_box(&scene).unwrap();
        let mut octants = [0; 8];
        for r in &rays {
            assert!(r.origin.cmpge(b.min).all() && r.origin.cmple(b.max).all(), "{r:?} outside {b:?}");
            assert!((r.direction.length() - 1.0).abs() < 1e-5 && r.t_min == 0.0 && r.t_max == f32::INFINITY);
            let d = r.direction;
            octants[usize::from(d.x < 0.0) | usize::from(d.y < 0.0) << 1 | usize::from(d.z < 0.0) << 2] += 1;
        }
        // About 150 per octant: uniform over the sphere, not a cone.
        assert!(octants.iter().all(|&n| (100..200).contains(&n)), "{octants:?}");
        assert_eq!(generate(&scene, &camera, 40, 30, RayKind::Random, 7).unwrap(), rays);
        assert_ne!(generate(&scene, &camera, 40, 30, RayKind::Random, 8).unwrap(), rays);
        assert_eq!("random".parse::<RayKind>().unwrap(), RayKind::Random);
        let mut planes = desc.build(crate::Accel::BvhSah).unwrap();
        planes.objects.retain(|o| matches!(o.geometry, crate::Geometry::Plane(_)));
        assert!(!planes.objects.is_empty());
        let err = generate(&planes, &camera, 4, 4, RayKind::Random, 1).unwrap_err().to_string();
        assert!(err.contains("random rays") && err.contains("bounded objects"), "{err}");
    }

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
        assert!(read_rays(&h).unwrap_err().to_string().contains("not a ray file"));
        // A hit file given as rays, and the other way round: said so.
        assert!(read_rays(&h).unwrap_err().to_string().contains("a hit file, not a ray file"), "{}", read_rays(&h).unwrap_err());
        assert!(read_hits(&p).unwrap_err().to_string().contains("a ray file, not a hit file"), "{}", read_hits(&p).unwrap_err());
        let short = dir.join("short.bin");
        std::fs::write(&short, b"ISIRRAYS\x01\0\0\0").unwrap();
        assert!(read_rays(&short).unwrap_err().to_string().contains("12 bytes: shorter than the 24-byte header"));
        let garbage = dir.join("g.bin");
        std::fs::write(&garbage, b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert!(read_rays(&garbage).unwrap_err().to_string().contains("not a ray file (it does not start with ISIRRAYS"));
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 5]).unwrap();
        assert!(read_rays(&p).unwrap_err().to_string().contains("header says 2"));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn sizes_that_disagree_with_the_header_are_rejected_with_both_numbers() {
        let dir = std::env::temp_dir().join(format!("isir-rays-size-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("r.bin");
        write_hits(&p, &[HitRecord::MISS; 3]).unwrap();
        let good = std::fs::read(&p).unwrap();
        assert_eq!(read_hits(&p).unwrap().len(), 3);
        // Trailing bytes: 3 records of 16 bytes, then 5 more.
        std::fs::write(&p, [&good[..], &[0u8; 5]].concat()).unwrap();
        let e = read_hits(&p).unwrap_err().to_string();
        assert!(e.contains("header says 3 records (48 bytes)") && e.contains("holds 53 bytes") && e.contains("and 5 bytes"), "{e}");
        // One whole record too many is an error too.
        std::fs::write(&p, [&good[..], &[0u8; 16]].concat()).unwrap();
        assert!(read_hits(&p).unwrap_err().to_string().contains("(4 records)"));
        // A count the file cannot hold: refused before allocating (2^40 records of 16
        // bytes would abort the process), and a count whose size overflows.
        for (count, claimed) in [(1u64 << 40, (1u64 << 44).to_string()), (u64::MAX, "more than 2^64".to_string())] {
            let mut b = good.clone();
            b[16..24].copy_from_slice(&count.to_le_bytes());
            std::fs::write(&p, b).unwrap();
            let e = read_hits(&p).unwrap_err().to_string();
            assert!(e.contains(&format!("header says {count} records ({claimed} bytes)")) && e.contains("holds 48 bytes"), "{e}");
        }
        #[cfg(unix)]
        assert!(read_rays(Path::new("/dev/zero")).unwrap_err().to_string().contains("not a regular file"));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn ray_sets_written_in_bands_are_the_generated_sets() {
        let dir = std::env::temp_dir().join(format!("isir-rays-bands-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let desc = crate::scenes::builtin("tp4-sphere").unwrap();
        let scene = desc.build(crate::Accel::BvhSah).unwrap();
        let (w, h) = (23, 17);
        let camera = desc.camera.build(w as f32 / h as f32);
        for kind in RayKind::ALL {
            let whole = dir.join("whole.rays");
            let set = generate(&scene, &camera, w, h, kind, 3).unwrap();
            write_rays(&whole, &set).unwrap();
            for band in [1, 4, 17, 100] {
                let banded = dir.join("banded.rays");
                let n = write_ray_set_in_bands(&banded, &scene, &camera, [w, h], kind, 3, band).unwrap();
                assert_eq!(n, set.len());
                assert_eq!(std::fs::read(&banded).unwrap(), std::fs::read(&whole).unwrap(), "{kind:?} in bands of {band} rows");
            }
            assert_eq!(write_ray_set(&dir.join("default.rays"), &scene, &camera, w, h, kind, 3).unwrap(), set.len());
        }
        // Not all pixels see the sphere or the walls: diffuse sets are shorter than primary.
        assert!(generate(&scene, &camera, w, h, RayKind::Primary, 3).unwrap().len() == (w * h) as usize);
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
        if occluded {
            let mut out = [false; CHUNK];
            mesh.occluded_batch(rays, &mut out);
            for (h, o) in hits.iter_mut().zip(out) {
                *h = if o { HitRecord::OCCLUDED } else { HitRecord::MISS };
            }
        } else {
            let mut out = [None; CHUNK];
            mesh.intersect_batch(rays, &mut out);
            for (h, o) in hits.iter_mut().zip(out) {
                *h = o.map_or(HitRecord::MISS, HitRecord::from);
            }
        }
    });
}

/// [`trace_mesh`] for closest hits of coherent rays: consecutive rays go in packets of
/// 16 through [`crate::accel::wide::WideBvh::intersect_packet`] when the mesh has a wide BVH
/// (one at a time otherwise). Same hits as [`trace_mesh`].
///
/// # Panics
/// If `hits` and `rays` differ in length.
pub fn trace_mesh_packets(mesh: &crate::TriangleMesh, rays: &[RayRecord], hits: &mut [HitRecord]) {
    use crate::accel::packet::PACKET;
    use crate::geometry::MeshAccel;
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
