//! Material and punctual-light parameters as glTF names them (glTF 2.0 section 3.9,
//! "Materials", and the specifications of KHR_materials_specular, _ior, _transmission,
//! _volume, _volume_scatter, _dispersion, _clearcoat, _sheen, _emissive_strength,
//! _diffuse_transmission and KHR_lights_punctual): one table per kind, shared by the
//! viewer's editor, view files' edits and the glTF writer. Each entry has the glTF property
//! name, where it lives in the material's (or light's) JSON, its valid range, and the
//! texture that scales it.

use super::light::{Cone, PunctualKind, PunctualLight};
use super::material::{AlphaMode, Material, TexRef};
use crate::medium::phase::MAX_G;
use glam::Vec3;

/// How glTF groups a material's parameters: the core material, or the extension holding them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    /// pbrMetallicRoughness, emissiveFactor, normalTexture.
    Core,
    /// alphaMode, alphaCutoff, doubleSided and the base colour's alpha.
    Alpha,
    /// KHR_materials_emissive_strength.
    EmissiveStrength,
    /// KHR_materials_specular.
    Specular,
    /// KHR_materials_ior.
    Ior,
    /// KHR_materials_transmission.
    Transmission,
    /// KHR_materials_volume.
    Volume,
    /// KHR_materials_volume_scatter.
    VolumeScatter,
    /// KHR_materials_dispersion.
    Dispersion,
    /// KHR_materials_clearcoat.
    Clearcoat,
    /// KHR_materials_sheen.
    Sheen,
    /// KHR_materials_diffuse_transmission.
    DiffuseTransmission,
    /// A KHR_lights_punctual light.
    Light,
}

impl Section {
    /// The material sections in the order the editor shows them.
    pub const MATERIAL: [Section; 12] = [
        Section::Core,
        Section::EmissiveStrength,
        Section::Specular,
        Section::Ior,
        Section::Transmission,
        Section::Volume,
        Section::VolumeScatter,
        Section::Dispersion,
        Section::Clearcoat,
        Section::Sheen,
        Section::DiffuseTransmission,
        Section::Alpha,
    ];

    /// Its title: the extension's name, or what the core properties are.
    pub fn title(self) -> &'static str {
        match self {
            Section::Core => "core PBR (pbrMetallicRoughness, emissive, normal)",
            Section::Alpha => "alpha and sides",
            Section::EmissiveStrength => "KHR_materials_emissive_strength",
            Section::Specular => "KHR_materials_specular",
            Section::Ior => "KHR_materials_ior",
            Section::Transmission => "KHR_materials_transmission",
            Section::Volume => "KHR_materials_volume",
            Section::VolumeScatter => "KHR_materials_volume_scatter",
            Section::Dispersion => "KHR_materials_dispersion",
            Section::Clearcoat => "KHR_materials_clearcoat",
            Section::Sheen => "KHR_materials_sheen",
            Section::DiffuseTransmission => "KHR_materials_diffuse_transmission",
            Section::Light => "KHR_lights_punctual",
        }
    }
}

/// What a parameter holds and its valid range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// A number in min..=max (an infinite max allows infinity, glTF's "absent").
    Number {
        /// Smallest value (f32::MIN_POSITIVE: any positive number).
        min: f32,
        /// Largest value.
        max: f32,
    },
    /// Linear RGB, each channel in 0..=max.
    Colour {
        /// Largest value of a channel.
        max: f32,
    },
    /// A point in the scene (finite).
    Position,
    /// A direction (finite, not zero; made a unit vector).
    Direction,
    /// On or off.
    Switch,
    /// One of these names.
    Choice(&'static [&'static str]),
}

/// A parameter's value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamValue {
    /// A number.
    Number(f32),
    /// A colour, position or direction.
    Triple(Vec3),
    /// On or off.
    Switch(bool),
    /// One of a choice's names.
    Choice(&'static str),
}

impl ParamValue {
    /// The number (0 for other kinds, which a checked value never is where a number is read).
    pub fn number(self) -> f32 {
        if let ParamValue::Number(x) = self { x } else { 0.0 }
    }

    /// The triple (zero for other kinds).
    pub fn triple(self) -> Vec3 {
        if let ParamValue::Triple(v) = self { v } else { Vec3::ZERO }
    }
}

impl Kind {
    /// Checks a value's kind and range; the error is one line without the parameter's name.
    pub fn check(self, value: ParamValue) -> Result<(), String> {
        let ok = match (self, value) {
            (Kind::Number { min, max }, ParamValue::Number(x)) => {
                (x.is_finite() || x == max) && (min..=max).contains(&x)
            }
            (Kind::Colour { max }, ParamValue::Triple(c)) => {
                c.is_finite() && c.min_element() >= 0.0 && c.max_element() <= max
            }
            (Kind::Position, ParamValue::Triple(p)) => p.is_finite(),
            (Kind::Direction, ParamValue::Triple(d)) => d.is_finite() && d.length_squared() > 0.0,
            (Kind::Switch, ParamValue::Switch(_)) => true,
            (Kind::Choice(names), ParamValue::Choice(c)) => names.contains(&c),
            _ => false,
        };
        if ok { Ok(()) } else { Err(format!("{} is not {}", describe(value), self.range())) }
    }

    /// The accepted values in words.
    pub fn range(self) -> String {
        match self {
            Kind::Number { min, max } => {
                let low = if min == f32::MIN_POSITIVE {
                    "a number above 0".to_string()
                } else {
                    format!("a number of at least {min}")
                };
                match max {
                    f32::INFINITY => format!("{low} (or inf)"),
                    f32::MAX => low,
                    _ if min == f32::MIN_POSITIVE => format!("in (0, {max}]"),
                    _ => format!("in {min}..={max}"),
                }
            }
            Kind::Colour { max: f32::MAX } => "a colour [r, g, b] of channels at least 0".into(),
            Kind::Colour { max } => format!("a colour [r, g, b] of channels in 0..={max}"),
            Kind::Position => "a finite point [x, y, z]".into(),
            Kind::Direction => "a direction [x, y, z], not zero".into(),
            Kind::Switch => "true or false".into(),
            Kind::Choice(names) => format!("one of {}", names.join(", ")),
        }
    }
}

fn describe(value: ParamValue) -> String {
    match value {
        ParamValue::Number(x) => format!("{x}"),
        ParamValue::Triple(v) => format!("[{}, {}, {}]", v.x, v.y, v.z),
        ParamValue::Switch(b) => format!("{b}"),
        ParamValue::Choice(c) => c.to_string(),
    }
}

/// Which elements of its JSON value a parameter is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// The whole value.
    Whole,
    /// The first three elements of a four-element array (baseColorFactor's colour).
    Rgb,
    /// The fourth element (baseColorFactor's alpha).
    Alpha,
}

/// One parameter of a material or light `T`.
pub struct Param<T: 'static> {
    /// Key in view files, e.g. "roughness".
    pub key: &'static str,
    /// The glTF property name, e.g. "roughnessFactor".
    pub gltf: &'static str,
    /// One line of help.
    pub help: &'static str,
    /// Where glTF groups it.
    pub section: Section,
    /// What it holds.
    pub kind: Kind,
    /// Its JSON path inside the material (or the light's KHR_lights_punctual entry); empty
    /// for a light's position and direction, which its node's transform holds.
    pub path: &'static [&'static str],
    /// Which elements of the value at `path` it is.
    pub part: Part,
    /// Its value.
    pub get: fn(&T) -> ParamValue,
    /// Sets it to a value that `kind` has checked (and keeps what depends on it up to date).
    pub set: fn(&mut T, ParamValue),
    /// The texture scaling it, and the texture's channels it reads.
    pub texture: fn(&T) -> Option<(TexRef, &'static str)>,
    /// Whether it means something for this material or light (alphaCutoff only in MASK mode).
    pub applies: fn(&T) -> bool,
}

impl<T> Param<T> {
    /// Checks `value` and, if it fits, sets it; the error is one line naming the parameter.
    pub fn try_set(&self, target: &mut T, value: ParamValue) -> Result<(), String> {
        if !(self.applies)(target) {
            return Err(format!("{} ({}) does not apply here", self.key, self.gltf));
        }
        self.kind.check(value).map_err(|e| format!("{}: {e}", self.key))?;
        (self.set)(target, value);
        Ok(())
    }
}

/// The parameters whose values differ between `original` and `edited`, in table order.
pub fn changes<T>(table: &'static [Param<T>], original: &T, edited: &T) -> Vec<(&'static Param<T>, ParamValue)> {
    table.iter().filter(|p| (p.get)(original) != (p.get)(edited)).map(|p| (p, (p.get)(edited))).collect()
}

/// The parameter of `table` with view-file key `key`.
pub fn find<T>(table: &'static [Param<T>], key: &str) -> Option<&'static Param<T>> {
    table.iter().find(|p| p.key == key)
}

fn always<T>(_: &T) -> bool {
    true
}

fn untextured<T>(_: &T) -> Option<(TexRef, &'static str)> {
    None
}

const UNIT: Kind = Kind::Number { min: 0.0, max: 1.0 };
const NON_NEGATIVE: Kind = Kind::Number { min: 0.0, max: f32::MAX };
const UNIT_COLOUR: Kind = Kind::Colour { max: 1.0 };

/// glTF's alphaMode names.
pub const ALPHA_MODES: &[&str] = &["OPAQUE", "MASK", "BLEND"];

/// Every material parameter the loader reads, in the order the editor shows them.
pub static MATERIAL_PARAMS: &[Param<Material>] = &[
    Param {
        key: "base_color",
        gltf: "baseColorFactor",
        help: "linear base colour (albedo of the diffuse base, tint of the metal)",
        section: Section::Core,
        kind: UNIT_COLOUR,
        path: &["pbrMetallicRoughness", "baseColorFactor"],
        part: Part::Rgb,
        get: |m| ParamValue::Triple(m.base_color),
        set: |m, v| m.base_color = v.triple(),
        texture: |m| m.base_color_tex.map(|t| (t, "RGB")),
        applies: always,
    },
    Param {
        key: "metallic",
        gltf: "metallicFactor",
        help: "metalness: 0 dielectric, 1 metal",
        section: Section::Core,
        kind: UNIT,
        path: &["pbrMetallicRoughness", "metallicFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.metallic),
        set: |m, v| m.metallic = v.number(),
        texture: |m| m.metallic_roughness_tex.map(|t| (t, "B")),
        applies: always,
    },
    Param {
        key: "roughness",
        gltf: "roughnessFactor",
        help: "perceptual roughness (GGX alpha = roughness^2)",
        section: Section::Core,
        kind: UNIT,
        path: &["pbrMetallicRoughness", "roughnessFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.roughness),
        set: |m, v| m.roughness = v.number(),
        texture: |m| m.metallic_roughness_tex.map(|t| (t, "G")),
        applies: always,
    },
    Param {
        key: "emissive",
        gltf: "emissiveFactor",
        help: "emitted colour, times emissiveStrength",
        section: Section::Core,
        kind: UNIT_COLOUR,
        path: &["emissiveFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Triple(m.emissive),
        set: |m, v| m.emissive = v.triple(),
        texture: |m| m.emissive_tex.map(|t| (t, "RGB")),
        applies: always,
    },
    Param {
        key: "normal_scale",
        gltf: "normalTexture.scale",
        help: "scale of the normal map's X and Y",
        section: Section::Core,
        kind: Kind::Number { min: -10.0, max: 10.0 },
        path: &["normalTexture", "scale"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.normal_scale),
        set: |m, v| m.normal_scale = v.number(),
        texture: |m| m.normal_tex.map(|t| (t, "RGB")),
        applies: |m| m.normal_tex.is_some(),
    },
    Param {
        key: "emissive_strength",
        gltf: "emissiveStrength",
        help: "multiplies emissiveFactor, so emission can exceed 1",
        section: Section::EmissiveStrength,
        kind: NON_NEGATIVE,
        path: &["extensions", "KHR_materials_emissive_strength", "emissiveStrength"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.emissive_strength),
        set: |m, v| m.emissive_strength = v.number(),
        texture: untextured,
        applies: always,
    },
    Param {
        key: "specular",
        gltf: "specularFactor",
        help: "strength of the dielectric's specular reflection",
        section: Section::Specular,
        kind: UNIT,
        path: &["extensions", "KHR_materials_specular", "specularFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.specular),
        set: |m, v| m.specular = v.number(),
        texture: |m| m.specular_tex.map(|t| (t, "A")),
        applies: always,
    },
    Param {
        key: "specular_color",
        gltf: "specularColorFactor",
        help: "tint of the dielectric's normal-incidence reflectance (F0)",
        section: Section::Specular,
        kind: Kind::Colour { max: f32::MAX },
        path: &["extensions", "KHR_materials_specular", "specularColorFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Triple(m.specular_color),
        set: |m, v| m.specular_color = v.triple(),
        texture: |m| m.specular_color_tex.map(|t| (t, "RGB")),
        applies: always,
    },
    Param {
        key: "ior",
        gltf: "ior",
        help: "index of refraction of the dielectric (1: index-matched, crossed unbent)",
        section: Section::Ior,
        kind: Kind::Number { min: 1.0, max: f32::MAX },
        path: &["extensions", "KHR_materials_ior", "ior"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.ior),
        set: |m, v| m.ior = v.number(),
        texture: untextured,
        applies: always,
    },
    Param {
        key: "transmission",
        gltf: "transmissionFactor",
        help: "share of the dielectric's light transmitted through the surface",
        section: Section::Transmission,
        kind: UNIT,
        path: &["extensions", "KHR_materials_transmission", "transmissionFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.transmission),
        set: |m, v| m.transmission = v.number(),
        texture: |m| m.transmission_tex.map(|t| (t, "R")),
        applies: always,
    },
    Param {
        key: "thickness",
        gltf: "thicknessFactor",
        help: "0: a thin wall; above 0: the mesh encloses a volume",
        section: Section::Volume,
        kind: NON_NEGATIVE,
        path: &["extensions", "KHR_materials_volume", "thicknessFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.volume_factors.thickness),
        set: |m, v| {
            m.volume_factors.thickness = v.number();
            m.update_volume();
        },
        texture: untextured,
        applies: always,
    },
    Param {
        key: "attenuation_color",
        gltf: "attenuationColor",
        help: "the colour white light becomes after attenuationDistance inside",
        section: Section::Volume,
        kind: UNIT_COLOUR,
        path: &["extensions", "KHR_materials_volume", "attenuationColor"],
        part: Part::Whole,
        get: |m| ParamValue::Triple(m.volume_factors.attenuation_color),
        set: |m, v| {
            m.volume_factors.attenuation_color = v.triple();
            m.update_volume();
        },
        texture: untextured,
        applies: always,
    },
    Param {
        key: "attenuation_distance",
        gltf: "attenuationDistance",
        help: "distance at which light has become attenuationColor (inf: no attenuation)",
        section: Section::Volume,
        kind: Kind::Number { min: f32::MIN_POSITIVE, max: f32::INFINITY },
        path: &["extensions", "KHR_materials_volume", "attenuationDistance"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.volume_factors.attenuation_distance),
        set: |m, v| {
            m.volume_factors.attenuation_distance = v.number();
            m.update_volume();
        },
        texture: untextured,
        applies: always,
    },
    Param {
        key: "multiscatter_color",
        gltf: "multiscatterColor",
        help: "the albedo the medium shows after many scattering events (black: no scattering)",
        section: Section::VolumeScatter,
        kind: UNIT_COLOUR,
        path: &["extensions", "KHR_materials_volume_scatter", "multiscatterColor"],
        part: Part::Whole,
        get: |m| ParamValue::Triple(m.volume_factors.multiscatter_color),
        set: |m, v| {
            m.volume_factors.multiscatter_color = v.triple();
            m.update_volume();
        },
        texture: untextured,
        applies: always,
    },
    Param {
        key: "scatter_anisotropy",
        gltf: "scatterAnisotropy",
        help: "Henyey-Greenstein g: below 0 back-scattering, above 0 forward",
        section: Section::VolumeScatter,
        kind: Kind::Number { min: -MAX_G, max: MAX_G },
        path: &["extensions", "KHR_materials_volume_scatter", "scatterAnisotropy"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.volume_factors.scatter_anisotropy),
        set: |m, v| {
            m.volume_factors.scatter_anisotropy = v.number();
            m.update_volume();
        },
        texture: untextured,
        applies: always,
    },
    Param {
        key: "dispersion",
        gltf: "dispersion",
        help: "20 / Abbe number: how much the index varies with wavelength (needs a volume)",
        section: Section::Dispersion,
        kind: NON_NEGATIVE,
        path: &["extensions", "KHR_materials_dispersion", "dispersion"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.dispersion),
        set: |m, v| m.dispersion = v.number(),
        texture: untextured,
        applies: always,
    },
    Param {
        key: "clearcoat",
        gltf: "clearcoatFactor",
        help: "strength of the clear coat layer",
        section: Section::Clearcoat,
        kind: UNIT,
        path: &["extensions", "KHR_materials_clearcoat", "clearcoatFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.clearcoat),
        set: |m, v| m.clearcoat = v.number(),
        texture: |m| m.clearcoat_tex.map(|t| (t, "R")),
        applies: always,
    },
    Param {
        key: "clearcoat_roughness",
        gltf: "clearcoatRoughnessFactor",
        help: "perceptual roughness of the clear coat",
        section: Section::Clearcoat,
        kind: UNIT,
        path: &["extensions", "KHR_materials_clearcoat", "clearcoatRoughnessFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.clearcoat_roughness),
        set: |m, v| m.clearcoat_roughness = v.number(),
        texture: |m| m.clearcoat_roughness_tex.map(|t| (t, "G")),
        applies: always,
    },
    Param {
        key: "sheen_color",
        gltf: "sheenColorFactor",
        help: "colour of the sheen (black: no sheen)",
        section: Section::Sheen,
        kind: UNIT_COLOUR,
        path: &["extensions", "KHR_materials_sheen", "sheenColorFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Triple(m.sheen_color),
        set: |m, v| m.sheen_color = v.triple(),
        texture: |m| m.sheen_color_tex.map(|t| (t, "RGB")),
        applies: always,
    },
    Param {
        key: "sheen_roughness",
        gltf: "sheenRoughnessFactor",
        help: "perceptual roughness of the sheen",
        section: Section::Sheen,
        kind: UNIT,
        path: &["extensions", "KHR_materials_sheen", "sheenRoughnessFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.sheen_roughness),
        set: |m, v| m.sheen_roughness = v.number(),
        texture: |m| m.sheen_roughness_tex.map(|t| (t, "A")),
        applies: always,
    },
    Param {
        key: "diffuse_transmission",
        gltf: "diffuseTransmissionFactor",
        help: "share of the diffuse base sent to the other side",
        section: Section::DiffuseTransmission,
        kind: UNIT,
        path: &["extensions", "KHR_materials_diffuse_transmission", "diffuseTransmissionFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Number(m.diffuse_transmission),
        set: |m, v| m.diffuse_transmission = v.number(),
        texture: |m| m.diffuse_transmission_tex.map(|t| (t, "A")),
        applies: always,
    },
    Param {
        key: "diffuse_transmission_color",
        gltf: "diffuseTransmissionColorFactor",
        help: "colour of the diffusely transmitted light",
        section: Section::DiffuseTransmission,
        kind: UNIT_COLOUR,
        path: &["extensions", "KHR_materials_diffuse_transmission", "diffuseTransmissionColorFactor"],
        part: Part::Whole,
        get: |m| ParamValue::Triple(m.diffuse_transmission_color),
        set: |m, v| m.diffuse_transmission_color = v.triple(),
        texture: |m| m.diffuse_transmission_color_tex.map(|t| (t, "RGB")),
        applies: always,
    },
    Param {
        key: "alpha",
        gltf: "baseColorFactor[3]",
        help: "opacity (used in MASK and BLEND modes)",
        section: Section::Alpha,
        kind: UNIT,
        path: &["pbrMetallicRoughness", "baseColorFactor"],
        part: Part::Alpha,
        get: |m| ParamValue::Number(m.alpha),
        set: |m, v| m.alpha = v.number(),
        texture: |m| m.base_color_tex.map(|t| (t, "A")),
        applies: always,
    },
    Param {
        key: "alpha_mode",
        gltf: "alphaMode",
        help: "OPAQUE ignores alpha, MASK cuts at alphaCutoff, BLEND lets 1 - alpha through",
        section: Section::Alpha,
        kind: Kind::Choice(ALPHA_MODES),
        path: &["alphaMode"],
        part: Part::Whole,
        get: |m| {
            ParamValue::Choice(match m.alpha_mode {
                AlphaMode::Opaque => "OPAQUE",
                AlphaMode::Mask(_) => "MASK",
                AlphaMode::Blend => "BLEND",
            })
        },
        set: |m, v| {
            m.alpha_mode = match (v, m.alpha_mode) {
                (ParamValue::Choice("MASK"), AlphaMode::Mask(c)) => AlphaMode::Mask(c),
                (ParamValue::Choice("MASK"), _) => AlphaMode::Mask(0.5),
                (ParamValue::Choice("BLEND"), _) => AlphaMode::Blend,
                _ => AlphaMode::Opaque,
            }
        },
        texture: untextured,
        applies: always,
    },
    Param {
        key: "alpha_cutoff",
        gltf: "alphaCutoff",
        help: "alpha below which a MASK material is cut away",
        section: Section::Alpha,
        kind: NON_NEGATIVE,
        path: &["alphaCutoff"],
        part: Part::Whole,
        get: |m| ParamValue::Number(if let AlphaMode::Mask(c) = m.alpha_mode { c } else { 0.5 }),
        set: |m, v| m.alpha_mode = AlphaMode::Mask(v.number()),
        texture: untextured,
        applies: |m| matches!(m.alpha_mode, AlphaMode::Mask(_)),
    },
    Param {
        key: "double_sided",
        gltf: "doubleSided",
        help: "whether the back side is seen (otherwise rays pass through it)",
        section: Section::Alpha,
        kind: Kind::Switch,
        path: &["doubleSided"],
        part: Part::Whole,
        get: |m| ParamValue::Switch(m.double_sided),
        set: |m, v| m.double_sided = v == ParamValue::Switch(true),
        texture: untextured,
        applies: always,
    },
];

fn spot(l: &PunctualLight) -> Cone {
    match l.kind {
        PunctualKind::Spot(cone) => cone,
        _ => Cone::new(0.0, std::f32::consts::FRAC_PI_4),
    }
}

const RIGHT_ANGLE: f32 = std::f32::consts::FRAC_PI_2;

/// Every punctual-light parameter the loader reads.
pub static LIGHT_PARAMS: &[Param<PunctualLight>] = &[
    Param {
        key: "color",
        gltf: "color",
        help: "linear RGB colour",
        section: Section::Light,
        kind: UNIT_COLOUR,
        path: &["color"],
        part: Part::Whole,
        get: |l| ParamValue::Triple(l.color),
        set: |l, v| l.color = v.triple(),
        texture: untextured,
        applies: always,
    },
    Param {
        key: "intensity",
        gltf: "intensity",
        help: "candela for point and spot lights, lux for directional ones",
        section: Section::Light,
        kind: NON_NEGATIVE,
        path: &["intensity"],
        part: Part::Whole,
        get: |l| ParamValue::Number(l.intensity),
        set: |l, v| l.intensity = v.number(),
        texture: untextured,
        applies: always,
    },
    Param {
        key: "position",
        gltf: "translation",
        help: "where the light is, in the scene's coordinates (written to its node)",
        section: Section::Light,
        kind: Kind::Position,
        path: &[],
        part: Part::Whole,
        get: |l| ParamValue::Triple(l.position),
        set: |l, v| l.position = v.triple(),
        texture: untextured,
        applies: |l| l.kind != PunctualKind::Directional,
    },
    Param {
        key: "direction",
        gltf: "rotation",
        help: "the direction the light shines along, in the scene's coordinates (its node's -z)",
        section: Section::Light,
        kind: Kind::Direction,
        path: &[],
        part: Part::Whole,
        get: |l| ParamValue::Triple(l.direction),
        set: |l, v| l.direction = v.triple().normalize(),
        texture: untextured,
        applies: |l| l.kind != PunctualKind::Point,
    },
    Param {
        key: "inner_cone_angle",
        gltf: "spot.innerConeAngle",
        help: "angle from the axis within which a spot light is at full intensity (radians)",
        section: Section::Light,
        kind: Kind::Number { min: 0.0, max: RIGHT_ANGLE },
        path: &["spot", "innerConeAngle"],
        part: Part::Whole,
        get: |l| ParamValue::Number(spot(l).inner()),
        set: |l, v| l.kind = PunctualKind::Spot(Cone::new(v.number(), spot(l).outer())),
        texture: untextured,
        applies: |l| matches!(l.kind, PunctualKind::Spot(_)),
    },
    Param {
        key: "outer_cone_angle",
        gltf: "spot.outerConeAngle",
        help: "angle from the axis beyond which a spot light gives no light (radians)",
        section: Section::Light,
        kind: Kind::Number { min: f32::MIN_POSITIVE, max: RIGHT_ANGLE },
        path: &["spot", "outerConeAngle"],
        part: Part::Whole,
        get: |l| ParamValue::Number(spot(l).outer()),
        set: |l, v| l.kind = PunctualKind::Spot(Cone::new(spot(l).inner(), v.number())),
        texture: untextured,
        applies: |l| matches!(l.kind, PunctualKind::Spot(_)),
    },
];

/// What is wrong with a light's parameters taken together (a spot's inner cone must be
/// narrower than its outer one), if anything.
pub fn light_problem(light: &PunctualLight) -> Option<String> {
    match light.kind {
        PunctualKind::Spot(cone) if cone.inner() >= cone.outer() => {
            Some(format!("innerConeAngle {} must be less than outerConeAngle {}", cone.inner(), cone.outer()))
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_parameter_reads_back_what_it_sets_and_ranges_are_checked() {
        for p in MATERIAL_PARAMS {
            let mut m = Material {
                normal_tex: Some(TexRef::plain(0)),
                alpha_mode: AlphaMode::Mask(0.3),
                ..Material::default()
            };
            let value = match p.kind {
                Kind::Number { min, max } => ParamValue::Number(if max == f32::INFINITY {
                    2.5
                } else {
                    0.25 * min.max(-1.0) + 0.75 * max.min(2.0)
                }),
                Kind::Colour { .. } => ParamValue::Triple(Vec3::new(0.25, 0.5, 0.75)),
                Kind::Switch => ParamValue::Switch(!(p.get)(&m).eq(&ParamValue::Switch(true))),
                Kind::Choice(_) => ParamValue::Choice("BLEND"),
                Kind::Position | Kind::Direction => unreachable!("materials have no points"),
            };
            assert_ne!((p.get)(&m), value, "{}: the test value differs from the default", p.key);
            p.try_set(&mut m, value).unwrap();
            assert_eq!((p.get)(&m), value, "{}", p.key);
            let bad = match p.kind {
                Kind::Number { .. } => ParamValue::Number(f32::NAN),
                Kind::Colour { .. } => ParamValue::Triple(Vec3::new(-0.1, 0.0, 0.0)),
                Kind::Switch => ParamValue::Number(1.0),
                _ => ParamValue::Choice("SOMETIMES"),
            };
            let err = p.try_set(&mut m, bad).unwrap_err();
            assert!(err.starts_with(p.key) && !err.contains('\n'), "{err}");
        }
    }

    #[test]
    fn volume_factors_make_the_medium_and_a_grid_stays() {
        let mut m = Material::default();
        find(MATERIAL_PARAMS, "thickness").unwrap().try_set(&mut m, ParamValue::Number(1.0)).unwrap();
        assert_eq!(m.volume.unwrap().sigma_t, Vec3::ZERO, "infinite distance: no attenuation");
        let distance = find(MATERIAL_PARAMS, "attenuation_distance").unwrap();
        distance.try_set(&mut m, ParamValue::Number(2.0)).unwrap();
        find(MATERIAL_PARAMS, "attenuation_color")
            .unwrap()
            .try_set(&mut m, ParamValue::Triple(Vec3::splat(0.5)))
            .unwrap();
        assert!((m.volume.unwrap().sigma_t - Vec3::splat(2f32.ln() / 2.0)).abs().max_element() < 1e-6);
        assert!(distance.try_set(&mut m, ParamValue::Number(0.0)).is_err(), "a distance must be positive");
        distance.try_set(&mut m, ParamValue::Number(f32::INFINITY)).unwrap();
        m.volume = Some(crate::medium::Volume { grid: Some(0), ..crate::medium::Volume::absorbing(Vec3::ONE) });
        find(MATERIAL_PARAMS, "thickness").unwrap().try_set(&mut m, ParamValue::Number(0.0)).unwrap();
        assert_eq!(m.volume.unwrap().grid, Some(0), "the media sidecar's grid is not the file's factors");
    }

    #[test]
    fn alpha_cutoff_applies_in_mask_mode_only_and_spot_cones_are_ordered() {
        let mut m = Material::default();
        let cutoff = find(MATERIAL_PARAMS, "alpha_cutoff").unwrap();
        assert!(cutoff.try_set(&mut m, ParamValue::Number(0.2)).unwrap_err().contains("does not apply"));
        find(MATERIAL_PARAMS, "alpha_mode").unwrap().try_set(&mut m, ParamValue::Choice("MASK")).unwrap();
        cutoff.try_set(&mut m, ParamValue::Number(0.2)).unwrap();
        assert_eq!(m.alpha_mode, AlphaMode::Mask(0.2));
        let mut light = PunctualLight {
            name: "s".into(),
            kind: PunctualKind::Spot(Cone::new(0.1, 0.5)),
            position: Vec3::ZERO,
            direction: -Vec3::Z,
            color: Vec3::ONE,
            intensity: 1.0,
            range: None,
            source: None,
        };
        assert_eq!(light_problem(&light), None);
        find(LIGHT_PARAMS, "inner_cone_angle").unwrap().try_set(&mut light, ParamValue::Number(0.6)).unwrap();
        assert!(light_problem(&light).unwrap().contains("less than outerConeAngle"));
        find(LIGHT_PARAMS, "direction")
            .unwrap()
            .try_set(&mut light, ParamValue::Triple(Vec3::new(0.0, 3.0, 4.0)))
            .unwrap();
        assert_eq!(light.direction, Vec3::new(0.0, 0.6, 0.8));
    }
}
