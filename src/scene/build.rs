//! Building a scene from a loader's description: triangles (bad and degenerate ones
//! dropped with a warning), the BVH, the light sampler and the feature set; and the cheap
//! copies the viewer's editors make.

use super::geometry::{self, Geometry, TriAttrs, TriExtra, Triangles};
use super::light::triangle::Emitters;
use super::light::{Light, LightSampler, PunctualLight};
use super::{Environment, FLAT_COS, Features, MAX_COORDINATE, Material, MeshDesc, Scene, SceneDesc};
use glam::{Affine3A, Vec2, Vec3, Vec4};
use std::sync::Arc;

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
        let singular = placements.iter().filter(|(_, t)| !geometry::placeable(t)).count();
        if singular > 0 {
            warnings.push(format!(
                "dropped {singular} placements whose transform flattens the mesh (zero scale), is not finite or reaches beyond 1e18"
            ));
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
        // In this order: the emissive triangles, the punctual lights, the environment.
        let lights = (self.emitters.lights.iter().map(|&t| Light::Triangle(t)))
            .chain(self.lights.iter().map(PunctualLight::light))
            .chain(self.environment.as_ref().map(|_| Light::Environment));
        let candidates = lights.map(|light| (light.power(self), light)).map(|(p, l)| (l, p)).collect();
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
    if !lo.cmple(hi).all() || !geometry::placeable(t) {
        return empty;
    }
    (0..8).fold(empty, |(a, b), k| {
        let corner = Vec3::select(glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0), hi, lo);
        let p = t.transform_point3(corner);
        (a.min(p), b.max(p))
    })
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn volume_meshes_must_be_closed_and_face_outwards() {
        use crate::scene::shapes::{cuboid, uv_sphere};
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
}
