//! The immutable scene: triangles in a BVH, materials, textures, lights, cameras, and the
//! set of effects it contains, which switches the integrator's per-bounce work. Building it
//! is `build`, finding and describing surface points `surface`, its lights `light`.

mod blas;
mod build;
pub mod camera;
pub mod edit;
pub mod geometry;
pub mod instances;
pub mod light;
pub mod material;
mod rgbe;
pub mod shading;
pub mod shapes;
pub mod surface;
pub mod texture;
mod watertight;
mod wide;

pub use light::environment;

use crate::medium::grid::DensityGrid;
use camera::Camera;
use environment::Environment;
use geometry::Geometry;
use glam::{Affine3A, Vec2, Vec3, Vec4};
use light::triangle::Emitters;
use light::{LightSampler, PunctualLight};
use material::Material;
use std::sync::Arc;
use texture::{Image, Texture};

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

    /// Whether a point, spot or directional light may shine through a transmitting
    /// material: caustics that only bidirectional estimators find.
    pub fn delta_lights_behind_glass(&self) -> bool {
        !self.lights.is_empty() && self.materials.iter().any(|m| m.is_transmissive())
    }

    /// Radius of a sphere around the scene's bounds.
    pub fn radius(&self) -> f32 {
        0.5 * (self.bounds.1 - self.bounds.0).length()
    }

    /// The material of triangle `tri`.
    pub fn material_at(&self, tri: u32) -> &Material {
        &self.materials[self.geometry.with_triangle(tri, |_, a, _| a.material) as usize]
    }
}
