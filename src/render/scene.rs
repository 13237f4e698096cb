//! The compiled scene the tracer reads: triangles in BVH order, materials, lights. It holds no
//! camera: a render's view (`Camera`, with its resolution) is made from a `CameraDesc` by
//! `Scene::view`, so one compiled scene and its BVH render from any camera and size.
//!
//! The builder moves every scene into one internal frame (bounds centred at the origin,
//! diagonal `INTERNAL_DIAGONAL`) by a similarity transform. Everything the methods compute from
//! distances is a ratio, or is compared with the projected pixel size in the same units, so it
//! is unchanged; but ray epsilons and the BVH's fixed 1e-4 entry distance then work the same
//! for scenes measured in millimetres or kilometres. Point-light intensity is the one
//! radiometric quantity with a length in it (E = I / r^2), so it is rescaled by s^2.
use super::camera::Camera;
use super::geometry::{gamma, BvhLayout, BvhQuality, Geometry, GeometryBuilder, Hit, NONE};
use super::light::{EnvironmentLight, Light, RectLight};
use super::material::Material;
use super::wide_bvh::{MAX_PACKET, MIN_PACKET};
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// Diagonal of the scene bounds in the internal frame.
pub const INTERNAL_DIAGONAL: f32 = 10.0;

/// The camera as described, before normalisation.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub vertical_fov_deg: f32,
    pub width: u32,
    pub height: u32,
}

#[derive(Clone, Debug)]
pub struct SceneBuilder {
    pub camera: CameraDesc,
    pub geometry: GeometryBuilder,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    pub objects: u32,
    /// Which of `geometry`'s triangles are rect lights' (their indices, in the lights' order).
    pub light_triangles: Vec<u32>,
    pub bvh_quality: BvhQuality,
    pub bvh_layout: BvhLayout,
}

impl SceneBuilder {
    pub fn new(camera: CameraDesc) -> Self {
        SceneBuilder {
            camera,
            geometry: GeometryBuilder::default(),
            materials: Vec::new(),
            lights: Vec::new(),
            objects: 0,
            light_triangles: Vec::new(),
            bvh_quality: BvhQuality::default(),
            bvh_layout: BvhLayout::default(),
        }
    }

    pub fn add_material(&mut self, m: Material) -> u32 {
        self.materials.push(m);
        (self.materials.len() - 1) as u32
    }

    /// A new object id.
    pub fn new_object(&mut self) -> u32 {
        self.objects += 1;
        self.objects - 1
    }

    /// Adds an area light and the two triangles that make it visible to camera rays (noted, so
    /// that an edit can move them: `Scene::with_lights`).
    pub fn add_rect_light(&mut self, light: RectLight) {
        let first = self.geometry.len();
        let index = self.lights.len() as u32;
        let material = self.add_material(Material::Emitter { light: index });
        let object = self.new_object();
        // Emission reads no surface coordinates: no uv table.
        let (c, u, v) = (light.corner, light.edge_u, light.edge_v);
        self.geometry.push([c, c + u, c + u + v], None, None, material, object);
        self.geometry.push([c, c + u + v, c + v], None, None, material, object);
        self.light_triangles.extend(first as u32..self.geometry.len() as u32);
        self.lights.push(Light::Rect(light));
    }

    /// Normalises into the internal frame and builds the BVH.
    pub fn build(mut self) -> Scene {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in self.geometry.positions.iter().flatten() {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        for l in &self.lights {
            if let Light::Point(p) = l {
                lo = lo.min(p.position);
                hi = hi.max(p.position);
            }
        }
        let diag = (hi - lo).length();
        let (center, scale) = if diag.is_finite() && diag > 0.0 {
            ((lo + hi) * 0.5, INTERNAL_DIAGONAL / diag)
        } else {
            (Vec3::ZERO, 1.0)
        };
        let to_internal = move |p: Vec3| (p - center) * scale;
        self.geometry.transform(to_internal, |n| n);
        to_internal_lights(&mut self.lights, center, scale);
        let degenerate_triangles = self.geometry.degenerate;
        let extent = if diag.is_finite() && diag > 0.0 { (hi - lo) * scale } else { Vec3::ZERO };
        let light_tris = self.light_triangles.iter().map(|&i| (i, self.geometry.positions[i as usize])).collect();
        Scene {
            default_camera: self.camera,
            origin: center,
            geometry: Arc::new(self.geometry.build(self.bvh_quality, self.bvh_layout)),
            glossy: any_glossy(&self.materials),
            materials: self.materials,
            lights: self.lights,
            light_tris,
            world_scale: scale,
            extent,
            objects: self.objects,
            degenerate_triangles,
        }
    }
}

/// Moves lights described in scene units into the internal frame (internal = (p - origin) *
/// scale).
fn to_internal_lights(lights: &mut [Light], origin: Vec3, scale: f32) {
    let to_internal = move |p: Vec3| (p - origin) * scale;
    for l in lights {
        match l {
            Light::Rect(r) => *r = r.rescaled(to_internal(r.corner), scale),
            Light::Point(p) => {
                p.position = to_internal(p.position);
                p.intensity *= scale * scale;
            }
            // Directions only: a similarity transform leaves them as they are.
            Light::Environment(_) => {}
        }
    }
}

#[derive(Debug)]
pub struct Scene {
    /// The camera the scene file describes, in scene units: the view a render takes when the
    /// request names none (`Scene::default_view`).
    pub default_camera: CameraDesc,
    /// The scene-unit point at the internal frame's origin (internal = (p - origin) * scale).
    pub origin: Vec3,
    /// Shared by the scenes that material and light edits make of this one (`with_lights`).
    pub geometry: Arc<Geometry>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    /// The rect lights' triangles: their index in the builder (`Geometry::source`) and their
    /// vertices in the internal frame.
    pub light_tris: Vec<(u32, [Vec3; 3])>,
    /// Internal units per world unit.
    pub world_scale: f32,
    /// Size of the bounds along each axis, internal units.
    pub extent: Vec3,
    pub objects: u32,
    pub degenerate_triangles: usize,
    /// Whether any material has a glossy lobe (`Material::has_lobe`): then every rect light also
    /// draws a lobe-sampled direction at each vertex (`mis`), and the indirect strategies have a
    /// glossy part. Set from `materials` when the scene is built.
    pub glossy: bool,
}

/// Whether any of `materials` has a glossy lobe (`Scene::glossy`).
fn any_glossy(materials: &[Material]) -> bool {
    materials.iter().any(Material::has_lobe)
}

/// A shading point: a hit with its geometry resolved and normals facing the incoming ray.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    pub p: Vec3,
    /// Geometric normal, on the side the ray came from.
    pub ng: Vec3,
    /// Shading normal, on the same side as `ng`.
    pub ns: Vec3,
    pub uv: Vec2,
    pub material: u32,
    pub object: u32,
    pub t: f32,
    /// How far `p` may lie from the true surface along `ng`: the bound of pbrt-v4's
    /// Sec. 6.8.6 on the rounding error of the interpolated point, projected on the normal.
    pub offset: f32,
}

/// pbrt's ShadowEpsilon: a shadow ray to a point on a light stops this fraction short of it,
/// so that the light's own surface, which the point lies on up to rounding, does not count.
pub const SHADOW_EPSILON: f32 = 1e-4;

impl Surface {
    /// The origin of rays leaving the surface on `ng`'s side: `p` moved along `ng` by its
    /// error bound (pbrt-v4's `OffsetRayOrigin`), so that it is on the ray's side of the true
    /// surface and never farther from it than rounding needs. `offset` includes the rounding
    /// of this sum itself, which pbrt takes care of by rounding each coordinate away instead.
    /// A fixed offset carries points near an acute inner edge through the other face, and
    /// light leaks in.
    #[inline]
    pub fn spawn_origin(&self) -> Vec3 {
        self.p + self.ng * self.offset
    }

    /// The shadow ray from this surface to `target`: origin, unit direction and the distance
    /// at which it stops (pbrt-v4's `SpawnRayTo`); None when the target is on the surface.
    #[inline]
    pub fn ray_to(&self, target: Vec3) -> Option<(Vec3, Vec3, f32)> {
        let o = self.spawn_origin();
        let d = target - o;
        let dist = d.length();
        let tmax = dist * (1.0 - SHADOW_EPSILON);
        (tmax > 0.0).then(|| (o, d / dist, tmax))
    }
}

/// Why `Scene::with_lights` refused an edit.
#[derive(Debug, PartialEq, Eq)]
pub enum EditRefused {
    /// The edit has other materials or lights than the scene (count or kind): a new geometry.
    Shape,
    /// Lights moved in a tree that cannot be refitted (the ray benchmark's CWBVH layout).
    NoRefit,
}

impl Scene {
    /// This scene with its materials and lights replaced by `b`'s (a builder holding the
    /// materials and lights, in scene units, listed as at compile time), without building the
    /// BVH again: the geometry is shared, or copied and refitted when rect lights moved. The
    /// internal frame stays this scene's, so an edit that keeps lights within the scene's
    /// bounds gives the scene a fresh compile of the edited description would.
    pub fn with_lights(&self, mut b: SceneBuilder) -> Result<Scene, EditRefused> {
        let same_kinds = b.lights.len() == self.lights.len()
            && b.lights.iter().zip(&self.lights).all(|(a, o)| std::mem::discriminant(a) == std::mem::discriminant(o));
        if !same_kinds || b.materials.len() != self.materials.len() || b.light_triangles.len() != self.light_tris.len()
        {
            return Err(EditRefused::Shape);
        }
        let (origin, scale) = (self.origin, self.world_scale);
        b.geometry.transform(move |p| (p - origin) * scale, |n| n);
        to_internal_lights(&mut b.lights, origin, scale);
        // The edit's triangles in the order of this scene's, under this scene's indices.
        let light_tris: Vec<(u32, [Vec3; 3])> = (b.light_triangles.iter().zip(&self.light_tris))
            .map(|(&i, &(at, _))| (at, b.geometry.positions[i as usize]))
            .collect();
        let moved: Vec<(u32, [Vec3; 3])> =
            light_tris.iter().zip(&self.light_tris).filter(|(new, old)| new.1 != old.1).map(|(new, _)| *new).collect();
        let geometry = if moved.is_empty() {
            Arc::clone(&self.geometry)
        } else {
            Arc::new(self.geometry.with_moved(&moved).ok_or(EditRefused::NoRefit)?)
        };
        Ok(Scene {
            default_camera: self.default_camera.clone(),
            origin,
            geometry,
            glossy: any_glossy(&b.materials),
            materials: b.materials,
            lights: b.lights,
            light_tris,
            world_scale: scale,
            extent: self.extent,
            objects: self.objects,
            degenerate_triangles: self.degenerate_triangles,
        })
    }

    /// The view of `desc` (scene units) in the internal frame the tracer works in.
    pub fn view(&self, desc: &CameraDesc) -> Camera {
        let to_internal = |p: Vec3| (p - self.origin) * self.world_scale;
        let d = desc;
        Camera::new(to_internal(d.position), to_internal(d.look_at), d.up, d.vertical_fov_deg, d.width, d.height)
    }

    /// The view of the scene file's own camera.
    pub fn default_view(&self) -> Camera {
        self.view(&self.default_camera)
    }

    pub fn triangle_count(&self) -> usize {
        self.geometry.triangle_count()
    }

    /// Largest dimension of the scene bounds (internal units).
    pub fn max_extent(&self) -> f32 {
        self.extent.max_element()
    }

    /// Closest surface along the ray.
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32) -> Option<Surface> {
        self.geometry.intersect(origin, dir, tmin, f32::INFINITY).map(|h| self.surface(&h, dir))
    }

    /// The closest surface along each ray from `origin` in `dirs[i]`, into `out`: what
    /// `intersect` finds for each, the rays traced together where they are coherent (a pixel's
    /// camera rays; `Geometry::intersect_many`). At most `MAX_PACKET` rays.
    pub fn intersect_many(&self, origin: Vec3, dirs: &[Vec3], tmin: f32, out: &mut [Option<Surface>]) {
        assert!(dirs.len() == out.len() && dirs.len() <= MAX_PACKET, "one surface per ray, at most a packet");
        let n = dirs.len();
        if n < MIN_PACKET {
            for (o, &d) in out.iter_mut().zip(dirs) {
                *o = self.intersect(origin, d, tmin);
            }
            return;
        }
        let mut rays = [(origin, Vec3::Z); MAX_PACKET];
        for (r, &d) in rays.iter_mut().zip(dirs) {
            r.1 = d;
        }
        let mut hits = [None; MAX_PACKET];
        self.geometry.intersect_many(&rays[..n], tmin, f32::INFINITY, &mut hits[..n]);
        for ((o, h), &d) in out.iter_mut().zip(hits).zip(dirs) {
            *o = h.map(|h| self.surface(&h, d));
        }
    }

    fn surface(&self, h: &Hit, dir: Vec3) -> Surface {
        let g = &self.geometry;
        let attr = g.attrs[h.slot as usize];
        let b0 = 1.0 - h.b1 - h.b2;
        // The point from the barycentrics, not origin + t dir: its error is then small and
        // bounded (pbrt-v4 Sec. 6.8.6: gamma(7) times the sum of |b_i p_i|), plus the rounding
        // of the vertices rebuilt from the stored edges.
        let [p0, p1, p2] = g.vertices(h.slot);
        let (w0, w1, w2) = (p0 * b0, p1 * h.b1, p2 * h.b2);
        let p = w0 + w1 + w2;
        let err = (w0.abs() + w1.abs() + w2.abs()) * gamma(7) + p0.abs().max(p1.abs()).max(p2.abs()) * gamma(2);
        let mut ng = g.geometric_normal(h.slot);
        if ng.dot(dir) > 0.0 {
            ng = -ng;
        }
        let mut ns = if attr.normals == NONE {
            ng
        } else {
            let n = g.normals[attr.normals as usize];
            (n[0] * b0 + n[1] * h.b1 + n[2] * h.b2).normalize_or_zero()
        };
        if ns == Vec3::ZERO {
            ns = ng;
        } else if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        let uv = if attr.uvs == NONE {
            Vec2::new(h.b1, h.b2)
        } else {
            let t = g.uvs[attr.uvs as usize];
            t[0] * b0 + t[1] * h.b1 + t[2] * h.b2
        };
        // Plus one ulp of the largest coordinate: moving p along ng rounds each coordinate by
        // at most half an ulp, which can take back at most sqrt(3)/2 ulp along ng.
        let offset = ng.abs().dot(err) + p.abs().max_element() * f32::EPSILON;
        Surface { p, ng, ns, uv, material: attr.material, object: attr.object, t: h.t, offset }
    }

    /// The environment light, if the scene has one.
    #[inline]
    pub fn environment(&self) -> Option<&EnvironmentLight> {
        self.lights.iter().find_map(|l| match l {
            Light::Environment(e) => Some(e),
            _ => None,
        })
    }

    /// Radiance arriving along a ray that leaves the scene in direction `dir`: the
    /// environment's, or black.
    #[inline]
    pub fn background(&self, dir: Vec3) -> Vec3 {
        self.environment().map_or(Vec3::ZERO, |e| e.radiance(dir))
    }

    /// True when nothing blocks the ray from surface `s` in direction `dir` (on `s.ng`'s side):
    /// the environment is visible that way.
    #[inline]
    pub fn escapes(&self, s: &Surface, dir: Vec3) -> bool {
        !self.geometry.occluded(s.spawn_origin(), dir, 0.0, f32::INFINITY)
    }

    /// True when something blocks the segment from surface `s` to `target` (on `s.ng`'s
    /// side), the target's own surface excepted (`Surface::ray_to`).
    #[inline]
    pub fn occluded(&self, s: &Surface, target: Vec3) -> bool {
        match s.ray_to(target) {
            Some((o, dir, tmax)) => self.geometry.occluded(o, dir, 0.0, tmax),
            None => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::light::{EmissionProfile, PointLight};

    fn desc() -> CameraDesc {
        CameraDesc {
            position: Vec3::new(0.0, 0.0, 5.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vertical_fov_deg: 40.0,
            width: 8,
            height: 8,
        }
    }

    #[test]
    fn normalisation_is_a_similarity_and_rescales_point_intensity() {
        for s in [1e-3f32, 1.0, 1e4] {
            let mut b = SceneBuilder::new(CameraDesc { position: Vec3::new(0.0, 0.0, 5.0) * s, ..desc() });
            let m = b.add_material(Material::Emitter { light: 0 });
            b.geometry.push([Vec3::ZERO, Vec3::X * s, Vec3::Y * s], None, None, m, 0);
            b.lights.push(Light::Point(PointLight { position: Vec3::new(0.0, 0.0, 1.0) * s, intensity: Vec3::ONE }));
            let scene = b.build();
            // Irradiance at the triangle's corner from the point light is invariant: I/r^2.
            let Light::Point(p) = &scene.lights[0] else { unreachable!() };
            let corner = scene.geometry.vertices(0).into_iter().fold(Vec3::splat(f32::INFINITY), Vec3::min);
            let e = p.intensity.x / (p.position - corner).length_squared();
            let expected = 1.0 / (s * s);
            assert!((e / expected - 1.0).abs() < 1e-4, "scale {s}: {e} vs {expected}");
            assert!((scene.max_extent() - INTERNAL_DIAGONAL / 3f32.sqrt()).abs() < 1e-3);
        }
    }

    /// A closed solid (a prism whose cross-section is a thin wedge, with an acute inner edge)
    /// and a light outside it, beyond the wedge's upper face: every point inside on the lower
    /// face sees the light in front of it and must find it blocked, however close it lies to
    /// the inner edge or corners. An offset of a fixed length moves points near an acute edge
    /// through the other face, and the light leaks in (the offset wedge used before leaked at
    /// 1e-3 here). Nearer than about 1e-4 of the faces' size, the intersection test cannot
    /// tell the other face from rounding error (the bound in `Tri4::intersect`).
    #[test]
    fn light_does_not_leak_into_a_closed_solid_at_its_inner_edges_and_corners() {
        use crate::render::integrator::{direct_light_of, DirectLights};
        use crate::render::sampler::PixelSampler;
        use crate::render::texture::Texture;
        let (angle, len) = (10f32.to_radians(), 4.0);
        let mut b = SceneBuilder::new(desc());
        let m = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(0.5)) });
        let o = b.new_object();
        // Cross-section: apex a, lower face along +x to c, upper face at `angle` to d.
        let (a, c, d) = (Vec2::ZERO, Vec2::new(len, 0.0), Vec2::new(len * angle.cos(), len * angle.sin()));
        let at = |p: Vec2, z: f32| Vec3::new(p.x, p.y, z);
        let quad = |b: &mut SceneBuilder, p: Vec2, q: Vec2| {
            let [p0, p1, q0, q1] = [at(p, -1.0), at(p, 1.0), at(q, -1.0), at(q, 1.0)];
            b.geometry.push([p0, q0, q1], None, None, m, o);
            b.geometry.push([p0, q1, p1], None, None, m, o);
        };
        quad(&mut b, a, c);
        quad(&mut b, c, d);
        quad(&mut b, d, a);
        b.geometry.push([at(a, -1.0), at(c, -1.0), at(d, -1.0)], None, None, m, o);
        b.geometry.push([at(a, 1.0), at(d, 1.0), at(c, 1.0)], None, None, m, o);
        b.add_rect_light(RectLight::new(
            Vec3::new(1.5, 2.0, -0.5),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::splat(10.0),
            EmissionProfile::Uniform,
        ));
        let scene = b.build();
        let internal = |p: Vec3| (p - scene.origin) * scene.world_scale;
        let Light::Rect(light) = &scene.lights[0] else { unreachable!() };
        let inside = internal(at((a + c + d) / 3.0, 0.3));
        let mut tested = 0;
        // Points on the lower face, from far to very near the apex edge and the caps' corners.
        for dist in [1.0f32, 1e-1, 1e-2, 3e-3, 1e-3] {
            for z in [0.0, -1.0 + dist, 1.0 - dist] {
                let target = internal(Vec3::new(dist, 0.0, z));
                let dir = (target - inside).normalize();
                let s = scene.intersect(inside, dir, 0.0).expect("a closed solid");
                assert!(
                    s.ng.y > 0.99 && (s.p - target).length() < 0.1 * dist,
                    "hit the lower face at {dist}: {s:?} {target}"
                );
                for (i, j) in (0..64).map(|k| (k % 8, k / 8)) {
                    let y = light.point([(i as f32 + 0.5) / 8.0, (j as f32 + 0.5) / 8.0]);
                    assert!(s.ng.dot(y - s.p) > 0.0);
                    assert!(scene.occluded(&s, y), "light leaks in {dist} from the edge, z {z}, sample {i} {j}");
                }
                let mut sampler = PixelSampler::new(7, tested, 0);
                let (light_in, _) = direct_light_of(&scene, &s, -dir, &mut sampler, DirectLights::All);
                assert_eq!(light_in, Vec3::ZERO, "{dist} {z}");
                tested += 1;
            }
        }
    }

    /// Rays leaving a surface from `Surface::spawn_origin` never hit that surface or its
    /// coplanar neighbour, at any size and direction, grazing ones included; from the point
    /// itself (no offset) some do, though the intersection test's own error bound rejects
    /// most of those, so the check can fail.
    #[test]
    fn rays_leaving_a_surface_never_hit_it_again() {
        use crate::render::test_rng::Rng;
        use crate::render::texture::Texture;
        let mut r = Rng(0x9e37_79b9_7f4a_7c15);
        let mut unoffset_hits = 0;
        for size in [0.01f32, 0.1, 1.0, 3.0] {
            let (mut rays, mut offset_hits) = (0, 0);
            for _ in 0..40 {
                let mut b = SceneBuilder::new(desc());
                let m = b.add_material(Material::Lambertian { albedo: Texture::Constant(Vec3::splat(0.5)) });
                // Two specks at the corners of the internal frame's bounds fix its scale at 1, so
                // that the quad's position and size are internal units.
                let h = INTERNAL_DIAGONAL / 3f32.sqrt() / 2.0;
                for c in [Vec3::splat(-h), Vec3::splat(h)] {
                    let e = -c.signum() * 1e-3;
                    b.geometry.push([c, c + Vec3::X * e, c + Vec3::Y * e], None, None, m, 0);
                }
                let (c, n) = (r.v() * (2.5 - size), r.v().normalize());
                let u = n.any_orthonormal_vector() * size * 0.5;
                let v = n.cross(u);
                let q = [c - u - v, c + u - v, c + u + v, c - u + v];
                b.geometry.push([q[0], q[1], q[2]], None, None, m, 0);
                b.geometry.push([q[0], q[2], q[3]], None, None, m, 0);
                let scene = b.build();
                assert!((scene.world_scale - 1.0).abs() < 1e-4 && scene.origin.length() < 1e-4);
                for _ in 0..10 {
                    let target = c + u * (r.f() * 2.0 - 1.0) + v * (r.f() * 2.0 - 1.0);
                    let from = target + (n * (0.2 + r.f()) + r.v() * 0.5) * size.max(0.1);
                    let s = scene.intersect(from, (target - from).normalize(), 0.0).expect("aimed at the quad");
                    for k in 0..10 {
                        let mut w = r.v().normalize();
                        w = if w.dot(s.ng) < 0.0 { -w } else { w };
                        if k % 2 == 0 {
                            // Grazing: 1e-1 to 1e-5 radians above the plane.
                            let tangent = (w - s.ng * w.dot(s.ng)).normalize();
                            w = (tangent + s.ng * 10f32.powf(-1.0 - 4.0 * r.f())).normalize();
                        }
                        let again = |o: Vec3| scene.geometry.intersect(o, w, 0.0, f32::INFINITY).is_some();
                        rays += 1;
                        offset_hits += again(s.spawn_origin()) as u32;
                        unoffset_hits += again(s.p) as u32;
                    }
                }
            }
            assert_eq!(offset_hits, 0, "size {size}: {offset_hits} of {rays} rays hit their own surface");
        }
        assert!(unoffset_hits > 0, "no ray from the point itself hit the surface");
    }

    #[test]
    fn rect_light_is_visible_and_faces_its_normal() {
        let mut b = SceneBuilder::new(desc());
        b.add_rect_light(RectLight::new(
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::ONE,
            EmissionProfile::Uniform,
        ));
        let scene = b.build();
        let c = &scene.default_view();
        let s = scene.intersect(c.position, c.direction(3.3, 4.6), 0.0).expect("hits the light");
        assert!(matches!(scene.materials[s.material as usize], Material::Emitter { light: 0 }));
        assert!(s.ng.dot(c.forward()) < 0.0);
    }
}
