//! The immutable scene: triangles in a BVH, materials, textures, lights, cameras, and the
//! set of effects it contains, which switches the integrator's per-bounce work.

mod blas;
pub mod camera;
pub mod edit;
pub mod environment;
pub mod geometry;
pub mod instances;
pub mod light;
pub mod material;
mod rgbe;
pub mod shading;
pub mod shapes;
pub mod texture;
mod watertight;
mod wide;

use crate::math::{
    float::{gamma, interpolation_error, offset_ray_origin},
    luminance,
};
use crate::medium::grid::DensityGrid;
use camera::Camera;
use environment::Environment;
use geometry::{Geometry, Hit, Ray, TriAttrs, TriExtra, Triangles};
use glam::{Affine3A, Vec2, Vec3, Vec4, Vec4Swizzles};
use light::{LightRef, LightSampler, PunctualLight};
use material::{AlphaMode, Material};
use shading::terminator_offset;
use std::sync::Arc;
use texture::{ColorSpace, Image, Texture};

/// Effects a scene contains. `volumes` and `cutouts` switch per-bounce work in the
/// integrator and the traversal (a scene without them does not track media or filter hits);
/// the others describe the scene, for messages and for preparing tables.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Features {
    /// Some triangle emits light.
    pub emissive: bool,
    /// There are KHR_lights_punctual lights.
    pub punctual: bool,
    /// Some material reads a texture.
    pub textures: bool,
    /// Some material has a GGX lobe (otherwise every surface is Lambertian).
    pub glossy: bool,
    /// Some material lets paths into a refracting, absorbing volume (KHR_materials_volume):
    /// paths then track the volumes they are in.
    pub volumes: bool,
    /// Some material has alpha or is single-sided: intersections consult the material.
    pub cutouts: bool,
    /// Light arrives from an environment (a map or a background colour).
    pub environment: bool,
    /// Some volume scatters light (a participating medium): the volumetric path tracer runs.
    pub media: bool,
    /// Some surface may let light straight through (a smooth thin wall, or an interface
    /// index-matched to vacuum or to another volume: `Material::may_pass_straight`): shadow
    /// rays test what they cross instead of stopping at the first surface. Without it they
    /// still do where they start inside a volume, whose surfaces may overlap its own.
    pub see_through: bool,
    /// Some material's index of refraction varies with wavelength (KHR_materials_dispersion):
    /// the spectral kernel runs.
    pub dispersion: bool,
}

impl Features {
    /// Every effect switched on: the general path, for comparisons (spectral transport aside).
    pub const ALL: Self = Self {
        emissive: true,
        punctual: true,
        textures: true,
        glossy: true,
        volumes: true,
        cutouts: true,
        environment: true,
        media: true,
        see_through: true,
        // Dispersion chooses a different estimator (the spectral kernel), not an effect the
        // kernel skips when absent: it stays as the scene has it.
        dispersion: false,
    };
}

/// Largest vertex coordinate magnitude accepted: products of two coordinates (edge cross
/// products, squared distances) stay finite in f32, and the BVH's bounds stay meaningful.
pub const MAX_COORDINATE: f32 = 1e18;

/// Cosine of 0.1 degree: vertex normals closer than this to their facet's normal are the
/// facet's normal up to rounding.
const FLAT_COS: f32 = 0.999_998_5;

/// A triangle mesh, in world space or placed by `instances`, as a loader produces it.
#[derive(Clone, Debug, Default)]
pub struct MeshDesc {
    /// Name for messages.
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Vertex normals, if the file has them (face normals are used otherwise).
    pub normals: Option<Vec<Vec3>>,
    /// Texture coordinates (set 0), if any.
    pub uvs: Option<Vec<Vec2>>,
    /// Texture coordinates of set 1, if any.
    pub uvs1: Option<Vec<Vec2>>,
    /// Linear vertex colours (COLOR_0, RGBA), if any.
    pub colors: Option<Vec<Vec4>>,
    /// Tangents with the bitangent sign in w, if its material has a normal map, anisotropy or
    /// a clearcoat normal map.
    pub tangents: Option<Vec<Vec4>>,
    /// Triangle list; counter-clockwise triangles face the viewer.
    pub indices: Vec<u32>,
    /// Index into the materials.
    pub material: u32,
    /// KHR_materials_variants: (variant, material) for the variants that change it.
    pub variants: Vec<(u32, u32)>,
    /// Where the mesh is placed, object to world, when it is placed more than once: it is
    /// then stored once, in its own space, and traced through a BVH of its placements.
    /// Empty: the mesh is in world space, placed once.
    pub instances: Vec<Affine3A>,
}

/// Everything a loader produces: a plain description the `Scene` is built from.
#[derive(Default)]
pub struct SceneDesc {
    /// Name shown to the user (file stem).
    pub name: String,
    /// Meshes in world space, or in their own space with their placements.
    pub meshes: Vec<MeshDesc>,
    /// Materials, indexed by `MeshDesc::material`.
    pub materials: Vec<Material>,
    /// Textures referenced by materials.
    pub textures: Vec<Texture>,
    /// Images referenced by textures.
    pub images: Vec<Image>,
    /// Punctual lights in world space.
    pub lights: Vec<PunctualLight>,
    /// Cameras from the file, with their names; the first is the default view.
    pub cameras: Vec<(String, Camera)>,
    /// Density grids that volumes refer to (`Volume::grid`), fitted by `Scene::build` to
    /// the bounds of the meshes whose materials hold them.
    pub grids: Vec<DensityGrid>,
    /// Things the loader could not honour, one line each.
    pub warnings: Vec<String>,
    /// KHR_materials_variants' names, indexed like `MeshDesc::variants`.
    pub variants: Vec<String>,
}

impl SceneDesc {
    /// Gives every mesh its material in the KHR_materials_variants variant `name` (meshes the
    /// variant does not name keep their default material).
    pub fn select_variant(&mut self, name: &str) -> Result<(), String> {
        let Some(v) = self.variants.iter().position(|n| n == name) else {
            let known = if self.variants.is_empty() { "none".to_owned() } else { self.variants.join(", ") };
            return Err(format!("the scene has no material variant \"{name}\" (its variants: {known})"));
        };
        for mesh in &mut self.meshes {
            if let Some(&(_, material)) = mesh.variants.iter().find(|&&(w, _)| w as usize == v) {
                mesh.material = material;
            }
        }
        Ok(())
    }
}

/// A surface point found by a ray.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// Position (interpolated from the vertices).
    pub p: Vec3,
    /// Absolute error bound on `p`, per coordinate.
    pub p_error: Vec3,
    /// Unit geometric normal on the front side.
    pub ng: Vec3,
    /// Unit interpolated shading normal.
    pub ns: Vec3,
    /// Texture coordinates of sets 0 and 1.
    pub uv: [Vec2; 2],
    /// Vertex colour (white without COLOR_0).
    pub color: Vec4,
    /// Material index.
    pub material: u32,
    /// Triangle index (BVH order).
    pub tri: u32,
    /// Barycentric weights of the triangle's vertices.
    pub b: [f32; 3],
}

/// An immutable, shareable scene ready to render.
pub struct Scene {
    /// Name shown to the user.
    pub name: String,
    /// Triangles and BVH (shared by edited copies of the scene).
    pub geometry: Arc<Geometry>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Textures.
    pub textures: Vec<Texture>,
    /// Images behind the textures (shared by edited copies of the scene).
    pub images: Arc<Vec<Image>>,
    /// Density grids of heterogeneous volumes (shared by edited copies of the scene).
    pub grids: Arc<Vec<DensityGrid>>,
    /// Punctual lights.
    pub lights: Vec<PunctualLight>,
    /// Light from outside the scene, if any.
    pub environment: Option<Environment>,
    /// Power-proportional choice among all lights.
    pub light_sampler: LightSampler,
    /// The emissive triangles the light sampler chooses among, kept for copies with the same
    /// materials.
    emitters: Arc<Emitters>,
    /// Named cameras from the file.
    pub cameras: Vec<(String, Camera)>,
    /// Bounds of all geometry (min, max).
    pub bounds: (Vec3, Vec3),
    /// Effects present.
    pub features: Features,
    /// Loader and build warnings, one line each.
    pub warnings: Vec<String>,
    /// KHR_materials_variants' names (the viewer's picker reopens the file in one).
    pub variants: Vec<String>,
}

impl Scene {
    /// Flattens meshes to triangles (dropping degenerate or non-finite ones with a warning),
    /// builds the BVH, the light sampler and the feature set.
    pub fn build(desc: SceneDesc) -> Self {
        let SceneDesc {
            name,
            meshes,
            mut materials,
            textures,
            images,
            lights,
            cameras,
            mut grids,
            mut warnings,
            variants,
        } = desc;
        let mut material_bounds = vec![(Vec3::INFINITY, Vec3::NEG_INFINITY); materials.len().max(1)];
        if materials.is_empty() {
            materials.push(Material::default());
        }
        let has_extra = meshes.iter().any(|m| m.uvs1.is_some() || m.colors.is_some() || m.tangents.is_some());
        let mut world = Triangles::default();
        let (mut instanced, mut placements) = (Vec::new(), Vec::new());
        let mut dropped = Dropped::default();
        for mesh in &meshes {
            let material = mesh.material.min(materials.len() as u32 - 1);
            if materials[material as usize].is_volume()
                && let Some(problem) = volume_problem(mesh)
            {
                let name = &materials[material as usize].name;
                warnings.push(format!("material \"{name}\" fills mesh \"{}\" with a volume, but {problem}", mesh.name));
            }
            let (lo, hi) = if mesh.instances.is_empty() {
                add_triangles(mesh, material, has_extra, &mut world, &mut dropped)
            } else {
                let mut own = Triangles::default();
                let (lo, hi) = add_triangles(mesh, material, has_extra, &mut own, &mut dropped);
                let index = instanced.len() as u32;
                instanced.push(own);
                placements.extend(mesh.instances.iter().map(|&t| (index, t)));
                mesh.instances
                    .iter()
                    .map(|t| transformed_box(lo, hi, t))
                    .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), (lo, hi)| (a.min(lo), b.max(hi)))
            };
            let b = &mut material_bounds[material as usize];
            *b = (b.0.min(lo), b.1.max(hi));
        }
        if dropped.bad > 0 {
            warnings.push(format!(
                "dropped {} triangles with missing, NaN, infinite or out-of-range (beyond 1e18) vertices",
                dropped.bad
            ));
        }
        if dropped.degenerate > 0 {
            warnings.push(format!("dropped {} degenerate (zero-area) triangles", dropped.degenerate));
        }
        let singular = placements.iter().filter(|(_, t)| !geometry::invertible(t)).count();
        if singular > 0 {
            warnings.push(format!("dropped {singular} placements whose transform flattens the mesh (zero scale)"));
        }
        let bounds =
            material_bounds.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), b| (lo.min(b.0), hi.max(b.1)));
        let bounds = if bounds.0.cmple(bounds.1).all() { bounds } else { (Vec3::ZERO, Vec3::ZERO) };
        // Each grid spans the bounds of the meshes whose material holds it.
        for (m, &(lo, hi)) in materials.iter().zip(&material_bounds) {
            if let Some(grid) = m.volume.and_then(|v| v.grid).and_then(|g| grids.get_mut(g as usize))
                && lo.cmple(hi).all()
            {
                grid.fit(lo, hi);
            }
        }
        let geometry = Arc::new(Geometry::build_instanced(world, instanced, &placements));
        let mut scene = Self {
            name,
            geometry,
            materials,
            textures,
            images: Arc::new(images),
            grids: Arc::new(grids),
            lights,
            environment: None,
            light_sampler: LightSampler::default(),
            emitters: Arc::default(),
            cameras,
            bounds,
            features: Features::default(),
            warnings,
            variants,
        };
        scene.emitters = Arc::new(Emitters::new(&scene.geometry, &scene.materials, &scene.textures, &scene.images));
        scene.update_lighting();
        scene
    }

    /// A copy with other materials and punctual lights, sharing the BVH and the images: only
    /// the light sampler and the feature set are rebuilt. Used by the viewer's editors.
    pub fn with_edits(&self, materials: Vec<Material>, lights: Vec<PunctualLight>) -> Self {
        self.copy(materials, lights, self.environment.clone())
    }

    /// A copy lit by `environment` (None, or a black one, for no light from outside).
    pub fn with_environment(&self, environment: Option<Environment>) -> Self {
        let environment = environment.filter(|e| !e.settings.is_black());
        self.copy(self.materials.clone(), self.lights.clone(), environment)
    }

    /// The copy keeps the emitters while the materials are the same.
    fn copy(&self, materials: Vec<Material>, lights: Vec<PunctualLight>, environment: Option<Environment>) -> Self {
        let emitters = if materials == self.materials {
            Arc::clone(&self.emitters)
        } else {
            Arc::new(Emitters::new(&self.geometry, &materials, &self.textures, &self.images))
        };
        let mut scene = Self {
            name: self.name.clone(),
            geometry: Arc::clone(&self.geometry),
            grids: Arc::clone(&self.grids),
            materials,
            textures: self.textures.clone(),
            images: Arc::clone(&self.images),
            lights,
            environment,
            light_sampler: LightSampler::default(),
            emitters,
            cameras: self.cameras.clone(),
            bounds: self.bounds,
            features: Features::default(),
            warnings: self.warnings.clone(),
            variants: self.variants.clone(),
        };
        scene.update_lighting();
        scene
    }

    /// Whether the scene lights itself: a punctual light, or an emissive surface whose
    /// emission is not textured (a lamp). Emissive textures (screens, indicator lights, a
    /// helmet's visor) decorate a model more than they light it, so a model with only
    /// those counts as unlit.
    pub fn has_own_light(&self) -> bool {
        let lamp = |m: &Material| m.is_emissive() && !m.unlit && m.emissive_tex.is_none();
        !self.lights.is_empty()
            || (self.materials.iter().any(lamp)
                && self.geometry.materials().any(|(_, m)| lamp(&self.materials[m as usize])))
    }

    /// Rebuilds the light sampler, from the emitters, the punctual lights and the
    /// environment, and the feature set.
    fn update_lighting(&mut self) {
        let (geometry, materials) = (&self.geometry, &self.materials);
        let mut candidates = self.emitters.candidates.clone();
        let radius = self.radius();
        candidates.extend(self.lights.iter().enumerate().map(|(i, l)| (LightRef::Punctual(i as u32), l.power(radius))));
        if let Some(env) = &self.environment {
            candidates.push((LightRef::Environment, env.power(radius)));
        }
        self.light_sampler = LightSampler::new(candidates, &self.emitters.areas);
        let mut seen = vec![false; materials.len()];
        geometry.materials().for_each(|(_, m)| seen[m as usize] = true);
        let used: Vec<&Material> = materials.iter().zip(seen).filter(|(_, s)| *s).map(|(m, _)| m).collect();
        // What a material's surface may border: vacuum, or another volume. A volume meets
        // itself only from inside itself, which a shadow ray starting outside every volume
        // reaches through a surface that already counts (see `Features::see_through`).
        let may_pass_straight = |m: &Material| {
            let others = used.iter().filter(|o| o.is_volume() && !std::ptr::eq(**o, m)).map(|o| o.ior);
            m.may_pass_straight(&std::iter::once(1.0).chain(others).collect::<Vec<f32>>())
        };
        self.features = Features {
            emissive: used.iter().any(|m| m.is_emissive()),
            punctual: !self.lights.is_empty(),
            textures: used.iter().any(|m| m.is_textured()),
            glossy: used.iter().any(|m| m.is_glossy()),
            volumes: used.iter().any(|m| m.is_volume()),
            cutouts: used.iter().any(|m| m.is_cutout()),
            environment: self.environment.is_some(),
            media: used.iter().any(|m| m.is_scattering()),
            see_through: used.iter().any(|m| may_pass_straight(m)),
            dispersion: used.iter().any(|m| m.is_dispersive()),
        };
    }

    /// The file's first camera, or one that frames the scene's bounds.
    pub fn default_camera(&self, aspect: f32) -> Camera {
        match self.cameras.first() {
            Some((_, cam)) => *cam,
            None => Camera::framing(self.bounds.0, self.bounds.1, aspect),
        }
    }

    /// What materials read from the scene to build their BSDFs.
    pub fn refs(&self) -> material::SceneRefs<'_> {
        material::SceneRefs { textures: &self.textures, images: &self.images, features: self.features }
    }

    /// The file's camera number `index` (0-based); the error is one line.
    pub fn file_camera(&self, index: usize) -> Result<Camera, String> {
        self.cameras.get(index).map(|(_, c)| *c).ok_or_else(|| {
            let n = self.cameras.len();
            format!("camera {index}: {} has {n} camera{}", self.name, if n == 1 { "" } else { "s" })
        })
    }

    /// Radius of a sphere around the scene's bounds.
    pub fn radius(&self) -> f32 {
        0.5 * (self.bounds.1 - self.bounds.0).length()
    }

    /// The material of triangle `tri`.
    pub fn material_at(&self, tri: u32) -> &Material {
        &self.materials[self.geometry.with_triangle(tri, |_, a, _| a.material) as usize]
    }

    /// Surface data at a hit, with the material's normal map applied to the shading normal.
    pub fn surface(&self, hit: &Hit) -> Surface {
        let b = hit.b;
        let lerp = |v: [Vec4; 3]| v[0] * b[0] + v[1] * b[1] + v[2] * b[2];
        self.geometry.with_triangle(hit.tri, |p, a, extra| {
            let mut surface = self.point_on(hit.tri, b, p, a, extra);
            // Flat triangles keep the facet's normal.
            if !a.is_flat() {
                let ns = (a.normals[0] * b[0] + a.normals[1] * b[1] + a.normals[2] * b[2]).normalize_or_zero();
                if ns != Vec3::ZERO {
                    surface.ns = ns;
                }
            }
            if let Some(e) = extra {
                surface.color = lerp(e.colors);
            }
            if let (Some(e), Some(map)) = (extra, self.materials[a.material as usize].normal_tex) {
                let tangent = lerp(e.tangents);
                let m = map.sample(&self.textures, &self.images, &surface.uv, ColorSpace::Linear).xyz() * 2.0 - 1.0;
                let scale = self.materials[a.material as usize].normal_scale;
                surface.ns = normal_mapped(surface.ns, tangent, m * Vec3::new(scale, scale, 1.0));
            }
            surface
        })
    }

    /// Interpolated tangent at `surface`, the bitangent sign in w; zero where its mesh has
    /// none (only meshes whose material has a normal map, anisotropy or a clearcoat normal
    /// map carry them). With it, the interpolated normal before normal mapping (the
    /// geometric one where the vertex normals cancel).
    pub fn tangent_space(&self, surface: &Surface) -> (Vec4, Vec3) {
        let b = surface.b;
        self.geometry.with_triangle(surface.tri, |_, a, extra| {
            let tangent =
                extra.map_or(Vec4::ZERO, |e| e.tangents[0] * b[0] + e.tangents[1] * b[1] + e.tangents[2] * b[2]);
            let n = a.normals;
            (tangent, (n[0] * b[0] + n[1] * b[1] + n[2] * b[2]).normalize_or(surface.ng))
        })
    }

    /// The point of triangle `tri` at barycentrics `b` as light sampling needs it, and
    /// `surface` starts from: position, its error bound, the geometric normal and the
    /// texture coordinates (for emission textures). The shading normal is the geometric one
    /// and the vertex colour white: no normal map is sampled, since an emitter's sample reads
    /// neither (2.5% of a Cornell render went to the full `surface` of light points).
    pub fn light_point(&self, tri: u32, b: [f32; 3]) -> Surface {
        self.geometry.with_triangle(tri, |p, a, extra| self.point_on(tri, b, p, a, extra))
    }

    /// What `light_point` gives that a light sample of uniform emission reads: the point,
    /// its error bound, the geometric normal and the material, without the texture
    /// coordinates and the rest of a `Surface` (4% of a Cornell box sample's instructions
    /// went to `light_point` and the area and emission lookups beside it).
    #[inline]
    pub fn light_position(&self, tri: u32, b: [f32; 3]) -> (Vec3, Vec3, Vec3, u32) {
        self.geometry.with_triangle(tri, |p, a, _| {
            let (point, error) = self.position_on(tri, b, p);
            (point, error, a.ng, a.material)
        })
    }

    /// The point of triangle `tri` (vertices `p`) at barycentrics `b`, and its error bound:
    /// the interpolation's and the placement's (pbrt-v4 section 6.8), and on every axis
    /// gamma(16) of the triangle's extent around the point, for the triangle test's own
    /// rounding of a ray that leaves it. The interpolation's bound vanishes along the normal
    /// of a coordinate plane through the origin, where reflections then started on the plane
    /// and a quarter of them found it again; its test in tests/robustness.rs needs 1.5 eps of
    /// the extent, and this is five times that.
    #[inline(always)]
    fn position_on(&self, tri: u32, b: [f32; 3], p: &[Vec3; 3]) -> (Vec3, Vec3) {
        let point = p[0] * b[0] + p[1] * b[1] + p[2] * b[2];
        let extent = (p[0] - point).abs().max((p[1] - point).abs()).max((p[2] - point).abs()).max_element();
        let test = Vec3::splat(gamma(16) * extent);
        (point, interpolation_error(b, *p) + self.geometry.placement_error(tri, b, point) + test)
    }

    /// `light_point` given the triangle's positions and attributes.
    #[inline(always)]
    fn point_on(&self, tri: u32, b: [f32; 3], p: &[Vec3; 3], a: &TriAttrs, extra: Option<&TriExtra>) -> Surface {
        let uv0 = a.uvs[0] * b[0] + a.uvs[1] * b[1] + a.uvs[2] * b[2];
        let uv1 = extra.map_or(uv0, |e| e.uv1[0] * b[0] + e.uv1[1] * b[1] + e.uv1[2] * b[2]);
        let (point, p_error) = self.position_on(tri, b, p);
        Surface {
            p: point,
            p_error,
            ng: a.ng,
            ns: a.ng,
            uv: [uv0, uv1],
            color: Vec4::ONE,
            material: a.material,
            tri,
            b,
        }
    }

    /// Closest hit along the ray. Materials with alpha let rays through where they are
    /// transparent; `camera` rays also pass the back of single-sided materials (what glTF's
    /// doubleSided means for the picture: back-face culling). Only camera rays cull: a path
    /// that turned into a closed single-sided mesh must still be stopped by its far side.
    pub fn intersect(&self, ray: &Ray, watertight: bool, camera: bool) -> Option<Hit> {
        if !self.features.cutouts {
            return self.geometry.intersect_with(ray, watertight);
        }
        self.geometry.intersect_filtered(ray, watertight, |tri, b| self.blocks(ray, tri, b, camera))
    }

    /// Whether anything blocks the ray before `tmax` (alpha as in `intersect`).
    pub fn occluded(&self, ray: &Ray, watertight: bool) -> bool {
        if !self.features.cutouts {
            return self.geometry.occluded_with(ray, watertight);
        }
        self.geometry.occluded_filtered(ray, watertight, |tri, b| self.blocks(ray, tri, b, false))
    }

    /// Whether a candidate hit counts. BLEND alpha is a coin flip hashed from the ray and the
    /// triangle, so the same ray always gets the same answer (determinism).
    fn blocks(&self, ray: &Ray, tri: u32, b: [f32; 3], camera: bool) -> bool {
        let (material, ng) = self.geometry.with_triangle(tri, |_, a, _| (a.material, a.ng));
        let m = &self.materials[material as usize];
        if camera && !m.double_sided && !m.is_volume() && ray.d.dot(ng) > 0.0 {
            return false;
        }
        if m.alpha_mode == AlphaMode::Opaque {
            return true;
        }
        let opacity = m.opacity(&self.textures, &self.images, &self.surface(&Hit { tri, t: 0.0, b }));
        match m.alpha_mode {
            AlphaMode::Mask(cutoff) => opacity >= cutoff,
            _ => {
                let key = (ray.o.x.to_bits() as u64) << 32 | ray.d.y.to_bits() as u64;
                let h = crate::math::sampler::hash3(key, (ray.d.x.to_bits() as u64) << 32 | tri as u64, 0xa1fa);
                ((h >> 40) as f32 / (1u64 << 24) as f32) < opacity
            }
        }
    }

    /// Where rays reflected at `surface` leave from, on its front side if `front` (the side
    /// the path arrived from) and its back side otherwise. With `terminator`, the point is
    /// first lifted onto the smooth surface of its vertex normals where that moves it out of
    /// the facet (Hanika 2021); with `offset`, it is then pushed past its floating-point
    /// error. Reflected directions above the shading normal but below the facet start there
    /// too: on a coarse convex mesh they escape, which is what removes the faceted shadow
    /// terminator; elsewhere they hit the facet and count as shadowed.
    pub fn reflection_origin(&self, surface: &Surface, front: bool, terminator: bool, offset: bool) -> Vec3 {
        let ng = if front { surface.ng } else { -surface.ng };
        let (mut p, mut error) = (surface.p, surface.p_error);
        // Flat triangles have nothing to lift.
        let lift = |positions: &[Vec3; 3], attrs: &TriAttrs| {
            (!attrs.is_flat()).then(|| {
                let normals = if front { attrs.normals } else { attrs.normals.map(|n| -n) };
                terminator_offset(p, surface.b, positions, &normals)
            })
        };
        if terminator
            && let Some(lift) = self.geometry.with_triangle(surface.tri, |positions, attrs, _| lift(positions, attrs))
            && lift.dot(ng) > 0.0
        {
            // The sum rounds by at most gamma(1) of its magnitude; lift's own rounding
            // only changes how far the point is lifted, not the side it ends up on.
            error += gamma(2) * (p.abs() + lift.abs());
            p += lift;
        }
        if offset { offset_ray_origin(p, error, ng, ng) } else { p }
    }
}

/// Triangles dropped while building: with bad vertices, or of zero area.
#[derive(Default)]
struct Dropped {
    bad: usize,
    degenerate: usize,
}

/// Appends `mesh`'s triangles to `out` with `material` (and their optional attributes if
/// `extra`), dropping those with bad vertices or zero area, which cannot be hit or sampled;
/// returns the bounds of those kept.
fn add_triangles(
    mesh: &MeshDesc,
    material: u32,
    extra: bool,
    out: &mut Triangles,
    dropped: &mut Dropped,
) -> (Vec3, Vec3) {
    let mut bounds = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for tri in mesh.indices.chunks_exact(3) {
        let idx = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        let p = idx.map(|i| mesh.positions.get(i).copied().unwrap_or(Vec3::NAN));
        if !p.iter().all(|v| v.is_finite() && v.abs().max_element() <= MAX_COORDINATE) {
            dropped.bad += 1;
            continue;
        }
        let cross = (p[1] - p[0]).cross(p[2] - p[0]);
        let ng = cross.normalize_or_zero();
        if ng == Vec3::ZERO || !ng.is_finite() {
            dropped.degenerate += 1;
            continue;
        }
        let normals = match &mesh.normals {
            Some(n) => idx.map(|i| {
                let n = n.get(i).map_or(Vec3::ZERO, |n| n.normalize_or_zero());
                // Normals within 0.1 degree of the facet's are snapped to it, so
                // that flat triangles are recognised as flat (no terminator lift).
                if n == Vec3::ZERO || !n.is_finite() || n.dot(ng) > FLAT_COS { ng } else { n }
            }),
            None => [ng; 3],
        };
        let uvs = match &mesh.uvs {
            Some(uv) => idx.map(|i| uv.get(i).copied().filter(|v| v.is_finite()).unwrap_or(Vec2::ZERO)),
            None => [Vec2::ZERO; 3],
        };
        bounds = p.iter().fold(bounds, |(lo, hi), &v| (lo.min(v), hi.max(v)));
        out.positions.push(p);
        out.attrs.push(TriAttrs::new(normals, uvs, ng, material));
        if extra {
            let per_vertex = |v: &Option<Vec<Vec4>>, default: Vec4| {
                idx.map(|i| v.as_ref().and_then(|v| v.get(i)).copied().filter(|v| v.is_finite()).unwrap_or(default))
            };
            let uv1 = match &mesh.uvs1 {
                Some(uv) => idx.map(|i| uv.get(i).copied().filter(|v| v.is_finite()).unwrap_or(Vec2::ZERO)),
                None => uvs,
            };
            let colors = per_vertex(&mesh.colors, Vec4::ONE);
            let tangents = per_vertex(&mesh.tangents, Vec4::ZERO);
            out.extra.push(TriExtra { uv1, colors, tangents });
        }
    }
    bounds
}

/// The world bounds of the box [lo, hi] placed by `t` (its corners transformed); empty
/// for an empty box or a transform that flattens it.
fn transformed_box(lo: Vec3, hi: Vec3, t: &Affine3A) -> (Vec3, Vec3) {
    let empty = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    if !lo.cmple(hi).all() || !geometry::invertible(t) {
        return empty;
    }
    (0..8).fold(empty, |(a, b), k| {
        let corner = Vec3::select(glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0), hi, lo);
        let p = t.transform_point3(corner);
        (a.min(p), b.max(p))
    })
}

/// The shading normal `n` perturbed by tangent-space normal `m` (glTF: +x along the
/// tangent, +y along the bitangent sign x n x t); `n` itself where there is no tangent.
fn normal_mapped(n: Vec3, tangent: Vec4, m: Vec3) -> Vec3 {
    let t = tangent.xyz() - n * n.dot(tangent.xyz());
    let t = t.normalize_or_zero();
    if t == Vec3::ZERO || !m.is_finite() {
        return n;
    }
    let sign = if tangent.w < 0.0 { -1.0 } else { 1.0 };
    let bitangent = sign * n.cross(t);
    let mapped = (t * m.x + bitangent * m.y + n * m.z).normalize_or_zero();
    if mapped == Vec3::ZERO { n } else { mapped }
}

/// Why `mesh` cannot bound a volume, if it cannot: the interface stack enters a volume at
/// front faces and leaves it at back faces, so the surface must be closed (every edge shared
/// by two triangles of opposite orientation, vertices welded by position) and face outwards
/// (positive signed volume).
fn volume_problem(mesh: &MeshDesc) -> Option<String> {
    use std::collections::HashMap;
    let (lo, hi) =
        mesh.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    // Welded within a millionth of the mesh's size: seams rebuilt from angles round differently.
    let cell = ((hi - lo).max_element() * 1e-6).max(f32::MIN_POSITIVE);
    let key = |p: Vec3| ((p - lo) / cell).round().as_ivec3().to_array();
    let mut edges: HashMap<([i32; 3], [i32; 3]), i32> = HashMap::new();
    let mut volume = 0.0f64;
    for tri in mesh.indices.chunks_exact(3) {
        let Some(p) = tri.iter().map(|&i| mesh.positions.get(i as usize).copied()).collect::<Option<Vec<Vec3>>>()
        else {
            continue;
        };
        if (p[1] - p[0]).cross(p[2] - p[0]) == Vec3::ZERO {
            continue;
        }
        let d = p.iter().map(|v| v.as_dvec3()).collect::<Vec<_>>();
        volume += d[0].dot(d[1].cross(d[2])) / 6.0;
        for (a, b) in [(p[0], p[1]), (p[1], p[2]), (p[2], p[0])] {
            let (ka, kb) = (key(a), key(b));
            if ka == kb {
                continue;
            }
            let (k, sign) = if ka < kb { ((ka, kb), 1) } else { ((kb, ka), -1) };
            *edges.entry(k).or_insert(0) += sign;
        }
    }
    let open = edges.values().filter(|&&n| n != 0).count();
    if open > 0 {
        Some(format!("it is not closed ({open} edges have no opposite): paths may enter without leaving"))
    } else if volume < 0.0 {
        Some("its faces point inwards (negative signed volume): paths would leave where they enter".into())
    } else {
        None
    }
}

/// The emissive triangles as light-sampling candidates, each with its power, and the area of
/// each emissive triangle (empty without any): integrating a textured emitter over its
/// triangles is most of building a light sampler, and a new environment changes none of it.
#[derive(Default)]
struct Emitters {
    candidates: Vec<(LightRef, f32)>,
    areas: Vec<f32>,
}

impl Emitters {
    fn new(geometry: &Geometry, materials: &[Material], textures: &[Texture], images: &[Image]) -> Self {
        let mean_emission: Vec<f32> = materials
            .iter()
            .map(|m| {
                if m.unlit {
                    return 0.0;
                }
                let tex = m.emissive_tex.map_or(Vec3::ONE, |t| {
                    images[textures[t.texture as usize].image as usize].mean(ColorSpace::Srgb).truncate()
                });
                luminance(m.emitted() * tex)
            })
            .collect();
        let mut emitters = Self::default();
        for (t, material) in geometry.materials() {
            let material = material as usize;
            let le = mean_emission[material];
            if le > 0.0 {
                let p = geometry.positions(t);
                let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
                let le = match materials[material].emissive_tex {
                    // A textured emitter is weighted by its texture over the triangle's UV
                    // footprint, mixed with a tenth of the texture's mean so that every triangle
                    // that may emit keeps a chance (explicit light sampling counts no other way).
                    Some(tex) => {
                        let uv = triangle_uvs(geometry, t, tex.set);
                        let footprint = footprint_emission(materials[material].emitted(), tex, uv, textures, images);
                        0.9 * footprint + 0.1 * le
                    }
                    None => le,
                };
                emitters.candidates.push((LightRef::Triangle(t), std::f32::consts::PI * area * le));
                if emitters.areas.is_empty() {
                    emitters.areas = vec![0.0; geometry.len()];
                }
                emitters.areas[t as usize] = area;
            }
        }
        emitters
    }
}

/// Texture coordinates of `set` (0 or 1) at the corners of triangle `t`.
fn triangle_uvs(geometry: &Geometry, t: u32, set: u8) -> [Vec2; 3] {
    match (set, geometry.extra(t)) {
        (1, Some(extra)) => extra.uv1,
        _ => geometry.attrs(t).uvs,
    }
}

/// Mean emitted luminance over a triangle with corner texture coordinates `uv`: `emitted`
/// times the texture at the centroids of the 16 equal-area cells of the triangle cut four
/// ways along each edge.
fn footprint_emission(
    emitted: Vec3,
    tex: material::TexRef,
    uv: [Vec2; 3],
    textures: &[Texture],
    images: &[Image],
) -> f32 {
    const N: usize = 4;
    let at = |a: f32, b: f32| {
        let p = uv[0] + (uv[1] - uv[0]) * a + (uv[2] - uv[0]) * b;
        luminance(emitted * tex.sample(textures, images, &[p, p], ColorSpace::Srgb).truncate())
    };
    let mut sum = 0.0;
    for i in 0..N {
        for j in 0..N - i {
            let (a, b) = (i as f32, j as f32);
            sum += at((a + 1.0 / 3.0) / N as f32, (b + 1.0 / 3.0) / N as f32);
            if i + j + 1 < N {
                sum += at((a + 2.0 / 3.0) / N as f32, (b + 2.0 / 3.0) / N as f32);
            }
        }
    }
    sum / (N * N) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn volume_meshes_must_be_closed_and_face_outwards() {
        use super::shapes::{cuboid, uv_sphere};
        assert_eq!(volume_problem(&cuboid(Vec3::ZERO, Vec3::ONE, false, 0)), None);
        assert_eq!(volume_problem(&uv_sphere(Vec3::ZERO, 1.0, 8, 16, false, 0)), None, "welded seams and poles");
        assert!(volume_problem(&cuboid(Vec3::ZERO, Vec3::ONE, true, 0)).unwrap().contains("inwards"));
        let mut open = cuboid(Vec3::ZERO, Vec3::ONE, false, 0);
        open.indices.truncate(30);
        assert!(volume_problem(&open).unwrap().contains("not closed (4 edges"));
        let desc = SceneDesc {
            meshes: vec![MeshDesc { name: "lid".into(), ..open }],
            materials: vec![Material::glass("ink", 1.3, Some(Vec3::ONE))],
            ..SceneDesc::default()
        };
        let scene = Scene::build(desc);
        assert!(scene.warnings.iter().any(|w| w.contains("\"ink\" fills mesh \"lid\"")), "{:?}", scene.warnings);
    }

    #[test]
    fn flat_triangles_shade_with_their_facet_normal_exactly() {
        // A tilted triangle without normals (flat), and one whose vertex normals fan out.
        let p = vec![Vec3::new(0.1, 0.2, 0.3), Vec3::new(1.7, 0.4, -0.2), Vec3::new(0.3, 1.9, 0.8)];
        let flat =
            MeshDesc { name: "flat".into(), positions: p.clone(), indices: vec![0, 1, 2], ..MeshDesc::default() };
        let fan = [Vec3::new(0.3, 0.1, 1.0), Vec3::new(-0.2, 0.3, 1.0), Vec3::new(0.1, -0.3, 1.0)];
        let smooth = MeshDesc {
            name: "smooth".into(),
            positions: p.iter().map(|v| *v + Vec3::Z * 5.0).collect(),
            normals: Some(fan.to_vec()),
            indices: vec![0, 1, 2],
            ..MeshDesc::default()
        };
        let desc = SceneDesc {
            meshes: vec![flat, smooth],
            materials: vec![Material::lambert("grey", Vec3::splat(0.5))],
            ..SceneDesc::default()
        };
        let scene = Scene::build(desc);
        let is_flat = |t: u32| scene.geometry.positions(t)[0].z < 1.0;
        let (mut rng, mut smooth_seen) = (rand_pcg::Pcg32::new(5, 3), 0);
        for _ in 0..2000 {
            use rand_core::RngCore;
            let mut u = || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
            let (b1, b2) = (u(), u());
            let b = if b1 + b2 > 1.0 { [b1 + b2 - 1.0, 1.0 - b1, 1.0 - b2] } else { [1.0 - b1 - b2, b1, b2] };
            for tri in 0..2 {
                let surface = scene.surface(&Hit { tri, t: 1.0, b });
                if is_flat(tri) {
                    assert_eq!(surface.ns, surface.ng, "a flat triangle at {b:?}");
                } else {
                    let n = fan.map(|n| n.normalize());
                    let want = (n[0] * b[0] + n[1] * b[1] + n[2] * b[2]).normalize();
                    assert!((surface.ns - want).length() < 1e-5 && surface.ns != surface.ng);
                    smooth_seen += 1;
                }
            }
        }
        assert_eq!(smooth_seen, 2000);
    }

    #[test]
    fn normal_maps_tilt_towards_the_tangent_and_mirrored_bitangents_flip() {
        let m = Vec3::new(0.6, 0.0, 0.8);
        assert!((normal_mapped(Vec3::Z, Vec4::new(1.0, 0.0, 0.0, 1.0), m) - m).length() < 1e-6);
        let up = Vec3::new(0.0, 0.6, 0.8);
        assert!((normal_mapped(Vec3::Z, Vec4::new(1.0, 0.0, 0.0, 1.0), up) - up).length() < 1e-6);
        let flipped = normal_mapped(Vec3::Z, Vec4::new(1.0, 0.0, 0.0, -1.0), up);
        assert!((flipped - Vec3::new(0.0, -0.6, 0.8)).length() < 1e-6, "{flipped}");
        assert_eq!(normal_mapped(Vec3::Z, Vec4::ZERO, m), Vec3::Z, "no tangent: no mapping");
    }

    /// Two emissive triangles of one area, at z = 0 and z = 1, mapped into the white left half
    /// and the black right half of a 16x1 emissive texture.
    fn screen_scene() -> Scene {
        use texture::Wrap;
        // A 16x1 emissive texture, white on its left half and black on its right; two
        // triangles of one area, one mapped into each half.
        let texels = (0..16).map(|x| if x < 8 { [255, 255, 255, 255] } else { [0, 0, 0, 255] }).collect();
        let tri = |u0: f32, z: f32| MeshDesc {
            name: "emitter".into(),
            positions: vec![Vec3::new(0.0, 0.0, z), Vec3::new(1.0, 0.0, z), Vec3::new(0.0, 1.0, z)],
            uvs: Some(vec![Vec2::new(u0, 0.1), Vec2::new(u0 + 0.4, 0.1), Vec2::new(u0, 0.9)]),
            indices: vec![0, 1, 2],
            ..MeshDesc::default()
        };
        let emitter = Material {
            emissive: Vec3::ONE,
            emissive_tex: Some(material::TexRef::plain(0)),
            ..Material::lambert("screen", Vec3::ZERO)
        };
        let desc = SceneDesc {
            meshes: vec![tri(0.05, 0.0), tri(0.55, 1.0)],
            materials: vec![emitter],
            textures: vec![Texture { name: "t".into(), image: 0, wrap: [Wrap::Repeat; 2], nearest: false }],
            images: vec![Image { width: 16, height: 1, texels: texture::Texels::Bytes(texels) }],
            ..SceneDesc::default()
        };
        Scene::build(desc)
    }

    /// The light sampler's probability of the screen's triangle at `z`.
    fn screen_pmf(scene: &Scene, z: f32) -> f32 {
        let t = (0..scene.geometry.len() as u32).find(|&t| scene.geometry.positions(t)[0].z == z).unwrap();
        scene.light_sampler.triangle_pmf(t)
    }

    #[test]
    fn textured_emitters_are_chosen_by_the_texture_over_their_footprint() {
        let scene = screen_scene();
        let pmf = |z: f32| screen_pmf(&scene, z);
        // White footprint: 0.9 x 1 + 0.1 x 0.5 (the texture's mean); black: 0.1 x 0.5.
        assert!((pmf(0.0) / pmf(1.0) - 19.0).abs() < 1e-3, "{} {}", pmf(0.0), pmf(1.0));
        assert!((pmf(0.0) + pmf(1.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn a_new_environment_keeps_the_emitters_and_edits_recompute_them() {
        let scene = screen_scene();
        let lit = scene.with_environment(Some(Environment::load(environment::EnvSettings::built_in()).unwrap()));
        let env = lit.light_sampler.environment_pmf();
        assert!(env > 0.0 && env < 1.0, "{env}");
        for z in [0.0, 1.0] {
            let (before, after) = (screen_pmf(&scene, z), screen_pmf(&lit, z));
            assert!((after / before - (1.0 - env)).abs() < 1e-5, "z = {z}: {before} then {after}");
        }
        // Edits keep the emitters while the materials stay, and integrate them again from
        // the new materials otherwise: the same materials give the same probabilities.
        let edited = lit.with_edits(lit.materials.clone(), lit.lights.clone());
        for z in [0.0, 1.0] {
            assert_eq!(screen_pmf(&edited, z).to_bits(), screen_pmf(&lit, z).to_bits(), "z = {z}");
        }
        // A black screen emits nothing: the edit leaves the environment alone to sample.
        let mut dark = lit.materials.clone();
        dark[0].emissive = Vec3::ZERO;
        let dark = lit.with_edits(dark, lit.lights.clone());
        assert_eq!((screen_pmf(&dark, 0.0), dark.light_sampler.environment_pmf()), (0.0, 1.0));
    }
}
