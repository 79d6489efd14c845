//! Lights (pbrt-v4's `Light`): a closed set of kinds, each in its own file (emissive
//! triangles, KHR_lights_punctual point, spot and directional lights, the environment),
//! a sampler that picks among them in proportion to their power, and the interface the
//! integrators sample lights through: `Scene::sample_li` beside its density
//! `Scene::pdf_li` (pbrt-v4's `Light::SampleLi` and `PDF_Li`), and for paths that start at
//! the lights, `Light::sample_le` beside `Light::pdf_le` (pbrt-v4's `SampleLe` and
//! `PDF_Le`). Shadow rays are the integrator's: a sample says where its shadow ray ends.

pub mod directional;
pub mod environment;
pub mod point;
pub mod punctual;
pub mod sampler;
pub mod spot;
pub mod triangle;

pub use directional::DirectionalLight;
pub use point::PointLight;
pub use punctual::{LightSource, PunctualKind, PunctualLight};
pub use sampler::LightSampler;
pub use spot::{Cone, SpotLight};
pub use triangle::TriangleLight;

use super::{Scene, Surface, geometry::Ray};
use crate::math::{frame::Frame, warp};
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// A light the sampler can choose. The environment's map is the scene's
/// (`Scene::environment`); punctual lights are boxed, so that each of the many triangles of
/// an emissive mesh takes 16 bytes.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// An emissive triangle.
    Triangle(TriangleLight),
    /// A point light.
    Point(Box<PointLight>),
    /// A spot light.
    Spot(Box<SpotLight>),
    /// A directional light.
    Directional(Box<DirectionalLight>),
    /// The environment.
    Environment,
}

impl Light {
    /// A point or direction on the light as seen from `p`, for the uniforms `u`, with the
    /// probability `pmf` of having chosen the light folded into the density. None where the
    /// sample carries no light (the back of an emitter, a spot's outside).
    #[inline]
    pub fn sample_li(&self, scene: &Scene, p: Vec3, u: Vec2, pmf: f32) -> Option<LightSample> {
        match self {
            Light::Triangle(t) => t.sample_li(scene, p, u, pmf),
            Light::Point(l) => l.sample_li(p, pmf),
            Light::Spot(l) => l.sample_li(p, pmf),
            Light::Directional(l) => l.sample_li(pmf),
            Light::Environment => scene.environment.as_ref()?.sample_li(u, pmf),
        }
    }

    /// A ray leaving the light, for the uniforms `u_pos` (where on it) and `u_dir` (which
    /// way); None where it carries nothing.
    pub fn sample_le(&self, scene: &Scene, u_pos: Vec2, u_dir: Vec2) -> Option<LightLeSample> {
        match self {
            Light::Triangle(t) => t.sample_le(scene, u_pos, u_dir),
            Light::Point(l) => l.sample_le(u_dir),
            Light::Spot(l) => l.sample_le(u_dir),
            Light::Directional(l) => l.sample_le(Disc::around(scene), u_pos),
            Light::Environment => scene.environment.as_ref()?.sample_le(Disc::around(scene), u_pos, u_dir),
        }
    }

    /// The densities with which `sample_le` returns a ray leaving along `w` from a point of
    /// (geometric) normal `n`: (per unit area of the origin, per solid angle of the
    /// direction). Delta distributions give 0 for what they fix (a point's direction is
    /// free, a directional light's is not).
    pub fn pdf_le(&self, scene: &Scene, n: Vec3, w: Vec3) -> (f32, f32) {
        match self {
            Light::Triangle(t) => t.pdf_le(n, w),
            Light::Point(_) => (0.0, warp::UNIFORM_SPHERE_PDF),
            Light::Spot(l) => (0.0, l.pdf_dir(w)),
            Light::Directional(_) => (Disc::around(scene).pdf(), 0.0),
            Light::Environment => match &scene.environment {
                Some(env) => (Disc::around(scene).pdf(), env.pdf(-w)),
                None => (0.0, 0.0),
            },
        }
    }

    /// Emitted power (luminance) for choosing among lights in `scene`, whose bounding
    /// sphere sizes the disc that light from infinitely far away crosses.
    pub fn power(&self, scene: &Scene) -> f32 {
        match self {
            Light::Triangle(t) => t.power,
            Light::Point(l) => l.power(),
            Light::Spot(l) => l.power(),
            Light::Directional(l) => l.power(scene.radius()),
            Light::Environment => scene.environment.as_ref().map_or(0.0, |e| e.power(scene.radius())),
        }
    }
}

/// Where a shadow ray towards a light sample ends.
#[derive(Clone, Copy, Debug)]
pub enum LightTarget {
    /// A point on an emitting surface, known to within `error`, with front normal `n`: the
    /// ray stops short of it by that bound.
    Surface {
        /// The point.
        p: Vec3,
        /// Absolute error bound on `p`, per coordinate.
        error: Vec3,
        /// The emitter's geometric normal.
        n: Vec3,
    },
    /// A point light's position.
    Point(Vec3),
    /// Infinitely far along the sample's direction (directional lights, the environment).
    Infinite,
}

/// A light sample for a reference point (pbrt-v4's `LightLiSample`).
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit world direction from the reference point towards the light.
    pub wi: Vec3,
    /// Radiance arriving along `wi` (for delta lights, intensity / d^2 or irradiance).
    pub radiance: Spectrum,
    /// Density of `wi` in solid angle, including the probability of choosing the light;
    /// for delta lights only that probability.
    pub pdf: f32,
    /// Where the shadow ray ends.
    pub target: LightTarget,
    /// The light is a delta (point, spot, directional): BSDF sampling cannot find it.
    pub is_delta: bool,
}

/// A ray leaving a light (pbrt-v4's `LightLeSample`), for paths that start at lights.
#[derive(Clone, Copy, Debug)]
pub struct LightLeSample {
    /// The ray: its origin on the light (for light from infinitely far, on a disc facing
    /// the scene from outside its bounding sphere) and its unit direction.
    pub ray: Ray,
    /// The emitting surface's geometric normal at the origin (area lights only).
    pub n: Option<Vec3>,
    /// What leaves along the ray: radiance for area lights and the environment, radiant
    /// intensity for point and spot lights, irradiance for directional lights.
    pub radiance: Spectrum,
    /// Density of the origin per unit area (1 for a point light's one point).
    pub pdf_pos: f32,
    /// Density of the direction per solid angle (1 for a directional light's one direction).
    pub pdf_dir: f32,
}

/// The disc that light from infinitely far away crosses on its way into the scene: centred
/// on the scene's bounding sphere, of its radius, facing the light's direction from the
/// sphere's edge (pbrt-v4's infinite lights' `SampleLe`).
#[derive(Clone, Copy, Debug)]
pub struct Disc {
    centre: Vec3,
    radius: f32,
}

impl Disc {
    /// The disc of `scene`'s bounding sphere.
    pub fn around(scene: &Scene) -> Self {
        Self { centre: 0.5 * (scene.bounds.0 + scene.bounds.1), radius: scene.radius().max(f32::MIN_POSITIVE) }
    }

    /// A point on the disc facing travel direction `d` (unit), outside the sphere, for the
    /// uniforms `u`.
    pub fn point(&self, d: Vec3, u: Vec2) -> Vec3 {
        let p = warp::concentric_disk(u) * self.radius;
        let frame = Frame::from_normal(d);
        self.centre + frame.to_world(Vec3::new(p.x, p.y, 0.0)) - d * self.radius
    }

    /// Density of `point` per unit area.
    pub fn pdf(&self) -> f32 {
        1.0 / (std::f32::consts::PI * self.radius * self.radius)
    }
}

/// Light a BSDF-sampled ray found, for `Scene::pdf_li`.
#[derive(Clone, Copy, Debug)]
pub enum LightHit<'a> {
    /// An emitting surface reached at `distance` (in units of the ray's direction) by a ray
    /// travelling along `-wo`.
    Emitter {
        /// The surface point.
        surface: &'a Surface,
        /// Direction back along the ray.
        wo: Vec3,
        /// Distance travelled from the last scattering vertex.
        distance: f32,
    },
    /// The environment, along this unit direction.
    Escaped(Vec3),
}

impl Scene {
    /// Radiance emitted by the front of `surface` (the same in every direction).
    pub fn emission(&self, surface: &Surface) -> Spectrum {
        self.materials[surface.material as usize].emission(&self.textures, &self.images, surface)
    }

    /// Samples a light, in proportion to power, and a point or direction on it for
    /// reference point `p`, from the uniforms `u_select` (which light) and `u` (where on it).
    /// None where the sample carries no light (the back of an emitter, a spot's outside).
    #[inline]
    pub fn sample_li(&self, p: Vec3, u_select: Vec2, u: Vec2) -> Option<LightSample> {
        let (light, pmf) = self.light_sampler.sample(u_select)?;
        light.sample_li(self, p, u, pmf)
    }

    /// Density with which `sample_li` would have sampled the light `hit` (solid angle,
    /// including the choice of the light), for MIS with the BSDF sample that found it.
    pub fn pdf_li(&self, hit: LightHit) -> f32 {
        match hit {
            LightHit::Emitter { surface, wo, distance } => {
                let pick = self.light_sampler.triangle(surface.tri);
                triangle::pdf_li(surface, wo, distance, pick.pmf, pick.area)
            }
            LightHit::Escaped(d) => match &self.environment {
                Some(env) => self.light_sampler.environment_pmf() * env.pdf(d),
                None => 0.0,
            },
        }
    }
}
