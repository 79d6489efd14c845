//! Material and punctual-light parameters as glTF names them (glTF 2.0 section 3.9,
//! "Materials", and the specifications of KHR_materials_specular, _ior, _transmission,
//! _volume, _volume_scatter, _dispersion, _clearcoat, _sheen, _emissive_strength,
//! _diffuse_transmission, _anisotropy, _iridescence and KHR_lights_punctual): one table per
//! kind, read by the glTF reader, the viewer's editor, view files' edits and the glTF
//! writer. Each entry is declared once: its field (whose name is its key in view files),
//! where it lives in the material's (or light's) JSON, its valid range (glTF's), and the
//! texture that scales it with where that texture's textureInfo lives. Its default is the
//! field's value in `Material::default()`, which is glTF's default except where an entry
//! says otherwise (doubleSided).

use super::light::{Cone, PunctualKind, PunctualLight};
use super::material::{AlphaMode, Material, TexRef};
use crate::medium::phase::MAX_G;
use glam::Vec3;
use serde_json::Value;
use std::fmt;

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
    /// KHR_materials_anisotropy.
    Anisotropy,
    /// KHR_materials_iridescence.
    Iridescence,
    /// A KHR_lights_punctual light.
    Light,
}

impl Section {
    /// The material sections in the order the editor shows them.
    pub const MATERIAL: [Section; 14] = [
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
        Section::Anisotropy,
        Section::Iridescence,
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
            Section::Anisotropy => "KHR_materials_anisotropy",
            Section::Iridescence => "KHR_materials_iridescence",
            Section::Light => "KHR_lights_punctual",
        }
    }

    /// The material extension whose object (in the material's `extensions`) holds its
    /// parameters; None for the material's own properties and a light's entry.
    pub fn extension(self) -> Option<&'static str> {
        match self {
            Section::Core | Section::Alpha | Section::Light => None,
            _ => Some(self.title()),
        }
    }
}

/// What a parameter holds and its valid range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// A number in min..=max (an infinite max allows infinity, glTF's "absent"; f32::MIN to
    /// f32::MAX is any finite number).
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

    /// Whether it is on (off for other kinds).
    pub fn switch(self) -> bool {
        self == ParamValue::Switch(true)
    }
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamValue::Number(x) => write!(f, "{x}"),
            ParamValue::Triple(v) => write!(f, "[{}, {}, {}]", v.x, v.y, v.z),
            ParamValue::Switch(b) => write!(f, "{b}"),
            ParamValue::Choice(c) => f.write_str(c),
        }
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
        if ok { Ok(()) } else { Err(format!("{value} is not {}", self.range())) }
    }

    /// The accepted values in words.
    pub fn range(self) -> String {
        match self {
            Kind::Number { min: f32::MIN, .. } => "a finite number".into(),
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

    /// Whether its range has no upper bound (a number or channel may be any finite amount
    /// above its minimum).
    fn open_ended(self) -> bool {
        matches!(self, Kind::Number { max, .. } | Kind::Colour { max } if max >= f32::MAX)
    }

    /// What the glTF reader uses for a file's `value` that `check` refuses: the nearest value
    /// of a bounded range (each channel's, for a colour); `default` for an open-ended range,
    /// a value that is not a number, or a value of another kind.
    pub fn repair(self, value: ParamValue, default: ParamValue) -> ParamValue {
        match (self, value) {
            (Kind::Number { min, max }, ParamValue::Number(x)) if !self.open_ended() && !x.is_nan() => {
                ParamValue::Number(x.clamp(min, max))
            }
            (Kind::Colour { max }, ParamValue::Triple(c)) if !self.open_ended() && c.is_finite() => {
                ParamValue::Triple(c.clamp(Vec3::ZERO, Vec3::splat(max)))
            }
            _ => default,
        }
    }

    /// Why `check` refuses `value`, in words: "is outside [0, 1]", "is below 1", "is not
    /// positive", "is not finite".
    pub fn violation(self, value: ParamValue) -> String {
        let finite = match value {
            ParamValue::Number(x) => x.is_finite(),
            ParamValue::Triple(v) => v.is_finite(),
            ParamValue::Switch(_) | ParamValue::Choice(_) => true,
        };
        match self {
            _ if !finite => "is not finite".into(),
            Kind::Number { min: f32::MIN_POSITIVE, .. } if self.open_ended() => "is not positive".into(),
            Kind::Number { min, .. } if self.open_ended() => format!("is below {min}"),
            Kind::Number { min, max } => format!("is outside [{min}, {max}]"),
            Kind::Colour { .. } if self.open_ended() => "is below 0".into(),
            Kind::Colour { max } => format!("is outside [0, {max}]"),
            _ => format!("is not {}", self.range()),
        }
    }

    /// A value of this kind in JSON (numbers as the reader's f32; `part` says which elements
    /// of an array it is); None for JSON of another kind.
    fn parse(self, part: Part, json: &Value) -> Option<ParamValue> {
        let number = |v: &Value| v.as_f64().map(|x| x as f32);
        let elements = |n: usize| json.as_array().filter(|a| a.len() == n);
        match (self, part) {
            (Kind::Number { .. }, Part::Alpha) => elements(4).and_then(|a| number(&a[3])).map(ParamValue::Number),
            (Kind::Number { .. }, _) => number(json).map(ParamValue::Number),
            (Kind::Colour { .. } | Kind::Position | Kind::Direction, _) => {
                let a = elements(if part == Part::Rgb { 4 } else { 3 })?;
                Some(ParamValue::Triple(Vec3::new(number(&a[0])?, number(&a[1])?, number(&a[2])?)))
            }
            (Kind::Switch, _) => json.as_bool().map(ParamValue::Switch),
            (Kind::Choice(names), _) => names.iter().find(|n| json.as_str() == Some(n)).map(|n| ParamValue::Choice(n)),
        }
    }
}

/// Which elements of its JSON value a parameter is, or where else it lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// The whole value.
    Whole,
    /// The first three elements of a four-element array (baseColorFactor's colour).
    Rgb,
    /// The fourth element (baseColorFactor's alpha).
    Alpha,
    /// Not in the light's entry but in its node (its translation or rotation, the path), which
    /// the writer moves or turns.
    Node,
}

/// A material's texture slot scaling a parameter.
#[derive(Clone, Copy)]
pub struct TextureSlot<T: 'static> {
    /// Where its textureInfo lives, dotted, inside the parameter's section's object.
    pub path: &'static str,
    /// The texture's channels the parameter reads, e.g. "G".
    pub channels: &'static str,
    /// The slot's texture.
    pub get: fn(&T) -> Option<TexRef>,
    /// Sets the slot's texture.
    pub set: fn(&mut T, Option<TexRef>),
}

/// One parameter of a material or light `T`.
pub struct Param<T: 'static> {
    /// Key in view files (the field's name, for a parameter that is one field), e.g. "roughness".
    pub key: &'static str,
    /// One line of help.
    pub help: &'static str,
    /// Where glTF groups it.
    pub section: Section,
    /// What it holds, and its valid range: glTF's, which the reader, view files and the
    /// writer check and the editor's widget keeps to.
    pub kind: Kind,
    /// Where it lives, dotted, inside its section's object (the material, the extension's
    /// object in it, or a light's KHR_lights_punctual entry): "pbrMetallicRoughness.roughnessFactor".
    pub path: &'static str,
    /// Which elements of the value at `path` it is.
    pub part: Part,
    /// Another spelling of `path` that the reader accepts where `path` is absent.
    pub alias: Option<&'static str>,
    /// Its value.
    pub get: fn(&T) -> ParamValue,
    /// Sets it to a value that `kind` has checked (and keeps what depends on it up to date).
    pub set: fn(&mut T, ParamValue),
    /// The texture scaling it.
    pub texture: Option<TextureSlot<T>>,
    /// Whether it means something for this material or light (alphaCutoff only in MASK mode).
    pub applies: fn(&T) -> bool,
    /// glTF's default where it is not `T::default()`'s value.
    pub gltf_default: Option<ParamValue>,
}

/// How a parameter reads and writes its field.
struct Field<T> {
    get: fn(&T) -> ParamValue,
    set: fn(&mut T, ParamValue),
}

impl<T> Param<T> {
    /// A parameter of `kind` at `path` in `section`'s object, whose view-file key is `key`:
    /// always applying, untextured, with `T::default()`'s default.
    const fn new(key: &'static str, section: Section, path: &'static str, kind: Kind, field: Field<T>) -> Self {
        Param {
            key,
            help: "",
            section,
            kind,
            path,
            part: Part::Whole,
            alias: None,
            get: field.get,
            set: field.set,
            texture: None,
            applies: always,
            gltf_default: None,
        }
    }

    /// With its line of help.
    const fn with_help(mut self, help: &'static str) -> Self {
        self.help = help;
        self
    }

    /// With the texture `slot` that scales it, of which it reads `channels`.
    const fn with_texture(mut self, slot: TextureSlot<T>, channels: &'static str) -> Self {
        self.texture = Some(TextureSlot { channels, ..slot });
        self
    }

    /// Applying only where `applies` says.
    const fn when(mut self, applies: fn(&T) -> bool) -> Self {
        self.applies = applies;
        self
    }

    /// Being `part` of the value at its path.
    const fn with_part(mut self, part: Part) -> Self {
        self.part = part;
        self
    }

    /// Read also at `alias` where its path is absent.
    const fn with_alias(mut self, alias: &'static str) -> Self {
        self.alias = Some(alias);
        self
    }

    /// With glTF's default `value`, which is not `T::default()`'s.
    const fn with_gltf_default(mut self, value: ParamValue) -> Self {
        self.gltf_default = Some(value);
        self
    }

    /// Its glTF name: its path without pbrMetallicRoughness, e.g. "roughnessFactor",
    /// "normalTexture.scale", "baseColorFactor[3]".
    pub fn name(&self) -> String {
        let name = self.path.strip_prefix("pbrMetallicRoughness.").unwrap_or(self.path);
        if self.part == Part::Alpha { format!("{name}[3]") } else { name.to_string() }
    }

    /// The keys leading from the material (or the light's entry) to it.
    pub fn keys(&self) -> impl Iterator<Item = &'static str> {
        keys(self.section, self.path)
    }

    /// Its value in `json`, a material (or a light's entry): None where the file does not
    /// give it (absent, or null), the JSON found where it is not of its kind.
    pub fn read<'a>(&self, json: &'a Value) -> Option<Result<ParamValue, &'a Value>> {
        let found = lookup(json, self.keys()).or_else(|| lookup(json, keys(self.section, self.alias?)))?;
        Some(self.kind.parse(self.part, found).ok_or(found))
    }

    /// Its texture's textureInfo in `json`, a material, where it has a texture the file gives.
    pub fn texture_info<'a>(&self, json: &'a Value) -> Option<&'a Value> {
        lookup(json, keys(self.section, self.texture.as_ref()?.path))
    }

    /// Checks `value` and, if it fits, sets it; the error is one line naming the parameter.
    pub fn try_set(&self, target: &mut T, value: ParamValue) -> Result<(), String> {
        if !(self.applies)(target) {
            return Err(format!("{} ({}) does not apply here", self.key, self.name()));
        }
        self.kind.check(value).map_err(|e| format!("{}: {e}", self.key))?;
        (self.set)(target, value);
        Ok(())
    }
}

impl<T: Default> Param<T> {
    /// Its value where the file does not give it: glTF's default.
    pub fn default_value(&self) -> ParamValue {
        self.gltf_default.unwrap_or_else(|| (self.get)(&T::default()))
    }
}

/// The keys leading from a material (or a light's entry) to `path` in `section`'s object.
fn keys(section: Section, path: &'static str) -> impl Iterator<Item = &'static str> {
    section.extension().map(|e| ["extensions", e]).into_iter().flatten().chain(path.split('.'))
}

/// The JSON at `keys` in `json`; None where it is absent or null.
fn lookup(json: &Value, mut keys: impl Iterator<Item = &'static str>) -> Option<&Value> {
    keys.try_fold(json, |v, k| v.get(k)).filter(|v| !v.is_null())
}

/// The parameters whose values differ between `original` and `edited`, in table order.
pub fn changes<T>(table: &'static [Param<T>], original: &T, edited: &T) -> Vec<(&'static Param<T>, ParamValue)> {
    table.iter().filter(|p| (p.get)(original) != (p.get)(edited)).map(|p| (p, (p.get)(edited))).collect()
}

/// The parameter of `table` with view-file key `key`.
pub fn find<T>(table: &'static [Param<T>], key: &str) -> Option<&'static Param<T>> {
    table.iter().find(|p| p.key == key)
}

/// Applies to every material or light.
fn always<T>(_: &T) -> bool {
    true
}

/// A factor in [0, 1].
const UNIT: Kind = Kind::Number { min: 0.0, max: 1.0 };
/// A finite number of at least 0.
const NON_NEGATIVE: Kind = Kind::Number { min: 0.0, max: f32::MAX };
/// An index of refraction: a finite number of at least 1.
const AT_LEAST_ONE: Kind = Kind::Number { min: 1.0, max: f32::MAX };
/// Any finite number.
const FINITE: Kind = Kind::Number { min: f32::MIN, max: f32::MAX };
/// A distance above 0, or infinite (glTF's "absent").
const POSITIVE_OR_INFINITE: Kind = Kind::Number { min: f32::MIN_POSITIVE, max: f32::INFINITY };
/// A Henyey-Greenstein g that the phase function can sample.
const HENYEY_GREENSTEIN_G: Kind = Kind::Number { min: -MAX_G, max: MAX_G };
/// A colour of channels in [0, 1].
const UNIT_COLOUR: Kind = Kind::Colour { max: 1.0 };
/// A colour of finite channels of at least 0.
const NON_NEGATIVE_COLOUR: Kind = Kind::Colour { max: f32::MAX };

/// glTF's alphaMode names.
pub const ALPHA_MODES: &[&str] = &["OPAQUE", "MASK", "BLEND"];

/// A parameter of field `$field` of a `$t` (its view-file key), a `ParamValue::$variant`
/// (read back by `ParamValue::$read`), at `$path` in section `$section`'s object, of range
/// `$kind`. A field of a material's `volume_factors` keeps its volume up to date.
macro_rules! field {
    ($t:ty, $variant:ident, $read:ident, volume_factors.$field:ident, $section:ident, $path:expr, $kind:expr) => {
        Param::new(
            stringify!($field),
            Section::$section,
            $path,
            $kind,
            Field::<$t> {
                get: |x| ParamValue::$variant(x.volume_factors.$field),
                set: |x, v| {
                    x.volume_factors.$field = v.$read();
                    x.update_volume();
                },
            },
        )
    };
    ($t:ty, $variant:ident, $read:ident, $field:ident, $section:ident, $path:expr, $kind:expr) => {
        Param::new(
            stringify!($field),
            Section::$section,
            $path,
            $kind,
            Field::<$t> { get: |x| ParamValue::$variant(x.$field), set: |x, v| x.$field = v.$read() },
        )
    };
}

/// A material parameter holding a number (see `field!`).
macro_rules! number {
    ($($args:tt)*) => { field!(Material, Number, number, $($args)*) };
}

/// A material parameter holding a colour (see `field!`).
macro_rules! colour {
    ($($args:tt)*) => { field!(Material, Triple, triple, $($args)*) };
}

/// Material texture slot `$field`, its textureInfo at `$path` in the section's object (the
/// channels read are the parameter's, `Param::with_texture`'s).
macro_rules! texture {
    ($field:ident, $path:expr) => {
        TextureSlot::<Material> { path: $path, channels: "", get: |m| m.$field, set: |m, t| m.$field = t }
    };
}

/// The base colour (RGB) and alpha (A) texture.
const BASE_COLOR_TEXTURE: TextureSlot<Material> = texture!(base_color_tex, "pbrMetallicRoughness.baseColorTexture");

/// The metalness (B) and roughness (G) texture.
const METALLIC_ROUGHNESS_TEXTURE: TextureSlot<Material> =
    texture!(metallic_roughness_tex, "pbrMetallicRoughness.metallicRoughnessTexture");

/// The iridescence film's thickness texture (G: from the minimum to the maximum).
const IRIDESCENCE_THICKNESS_TEXTURE: TextureSlot<Material> =
    texture!(iridescence_thickness_tex, "iridescenceThicknessTexture");

/// The base colour factor: the colour's RGB and alpha.
const BASE_COLOR_FACTOR: &str = "pbrMetallicRoughness.baseColorFactor";

/// A parameter table from its entries, each after its one line of help as a doc comment.
macro_rules! table {
    ($(#[doc = $help:literal] $param:expr),* $(,)?) => {
        &[$($param.with_help($help.trim_ascii())),*]
    };
}

/// Every material parameter glTF sets, in the order the reader reads them (alphaMode before
/// alphaCutoff) and the editor shows them.
pub static MATERIAL_PARAMS: &[Param<Material>] = table! {
    /// linear base colour (albedo of the diffuse base, tint of the metal)
    colour!(base_color, Core, BASE_COLOR_FACTOR, UNIT_COLOUR).with_part(Part::Rgb).with_texture(BASE_COLOR_TEXTURE, "RGB"),
    /// metalness: 0 dielectric, 1 metal
    number!(metallic, Core, "pbrMetallicRoughness.metallicFactor", UNIT).with_texture(METALLIC_ROUGHNESS_TEXTURE, "B"),
    /// perceptual roughness (GGX alpha = roughness^2)
    number!(roughness, Core, "pbrMetallicRoughness.roughnessFactor", UNIT).with_texture(METALLIC_ROUGHNESS_TEXTURE, "G"),
    /// emitted colour, times emissiveStrength
    colour!(emissive, Core, "emissiveFactor", UNIT_COLOUR).with_texture(texture!(emissive_tex, "emissiveTexture"), "RGB"),
    /// scale of the normal map's X and Y
    number!(normal_scale, Core, "normalTexture.scale", FINITE).with_texture(texture!(normal_tex, "normalTexture"), "RGB").when(has_normal_map),
    /// multiplies emissiveFactor, so emission can exceed 1
    number!(emissive_strength, EmissiveStrength, "emissiveStrength", NON_NEGATIVE),
    /// strength of the dielectric's specular reflection
    number!(specular, Specular, "specularFactor", UNIT).with_texture(texture!(specular_tex, "specularTexture"), "A"),
    /// tint of the dielectric's normal-incidence reflectance (F0)
    colour!(specular_color, Specular, "specularColorFactor", NON_NEGATIVE_COLOUR).with_texture(texture!(specular_color_tex, "specularColorTexture"), "RGB"),
    /// index of refraction of the dielectric (1: index-matched, crossed unbent)
    number!(ior, Ior, "ior", AT_LEAST_ONE),
    /// share of the dielectric's light transmitted through the surface
    number!(transmission, Transmission, "transmissionFactor", UNIT).with_texture(texture!(transmission_tex, "transmissionTexture"), "R"),
    /// 0: a thin wall; above 0: the mesh encloses a volume
    number!(volume_factors.thickness, Volume, "thicknessFactor", NON_NEGATIVE),
    /// the colour white light becomes after attenuationDistance inside
    colour!(volume_factors.attenuation_color, Volume, "attenuationColor", UNIT_COLOUR),
    /// distance at which light has become attenuationColor (inf: no attenuation)
    number!(volume_factors.attenuation_distance, Volume, "attenuationDistance", POSITIVE_OR_INFINITE),
    /// the albedo the medium shows after many scattering events (black: no scattering)
    colour!(volume_factors.multiscatter_color, VolumeScatter, "multiscatterColor", UNIT_COLOUR),
    /// Henyey-Greenstein g: below 0 back-scattering, above 0 forward
    number!(volume_factors.scatter_anisotropy, VolumeScatter, "scatterAnisotropy", HENYEY_GREENSTEIN_G),
    /// 20 / Abbe number: how much the index varies with wavelength (needs a volume)
    number!(dispersion, Dispersion, "dispersion", NON_NEGATIVE),
    /// strength of the clear coat layer
    number!(clearcoat, Clearcoat, "clearcoatFactor", UNIT).with_texture(texture!(clearcoat_tex, "clearcoatTexture"), "R"),
    /// perceptual roughness of the clear coat
    number!(clearcoat_roughness, Clearcoat, "clearcoatRoughnessFactor", UNIT).with_texture(texture!(clearcoat_roughness_tex, "clearcoatRoughnessTexture"), "G"),
    /// scale of the clear coat normal map's X and Y
    number!(clearcoat_normal_scale, Clearcoat, "clearcoatNormalTexture.scale", FINITE).with_texture(texture!(clearcoat_normal_tex, "clearcoatNormalTexture"), "RGB").when(has_clearcoat_normal_map),
    /// colour of the sheen (black: no sheen)
    colour!(sheen_color, Sheen, "sheenColorFactor", UNIT_COLOUR).with_texture(texture!(sheen_color_tex, "sheenColorTexture"), "RGB"),
    /// perceptual roughness of the sheen
    number!(sheen_roughness, Sheen, "sheenRoughnessFactor", UNIT).with_texture(texture!(sheen_roughness_tex, "sheenRoughnessTexture"), "A"),
    /// share of the diffuse base sent to the other side
    number!(diffuse_transmission, DiffuseTransmission, "diffuseTransmissionFactor", UNIT).with_texture(texture!(diffuse_transmission_tex, "diffuseTransmissionTexture"), "A"),
    /// colour of the diffusely transmitted light
    colour!(diffuse_transmission_color, DiffuseTransmission, "diffuseTransmissionColorFactor", UNIT_COLOUR).with_texture(texture!(diffuse_transmission_color_tex, "diffuseTransmissionColorTexture"), "RGB"),
    /// strength of the anisotropy, 0 isotropic (the texture's RG turn its direction)
    number!(anisotropy_strength, Anisotropy, "anisotropyStrength", UNIT).with_texture(texture!(anisotropy_tex, "anisotropyTexture"), "B"),
    /// direction of the anisotropy: radians counter-clockwise from the tangent
    number!(anisotropy_rotation, Anisotropy, "anisotropyRotation", FINITE),
    /// strength of the thin-film interference (0: no film)
    number!(iridescence, Iridescence, "iridescenceFactor", UNIT).with_texture(texture!(iridescence_tex, "iridescenceTexture"), "R"),
    /// index of refraction of the film (the extension's README spells it iridescenceIOR)
    number!(iridescence_ior, Iridescence, "iridescenceIor", AT_LEAST_ONE).with_alias("iridescenceIOR"),
    /// film thickness in nm where the thickness texture is 0
    number!(iridescence_thickness_min, Iridescence, "iridescenceThicknessMinimum", NON_NEGATIVE).with_texture(IRIDESCENCE_THICKNESS_TEXTURE, "G"),
    /// film thickness in nm where the thickness texture is 1, or without one
    number!(iridescence_thickness_max, Iridescence, "iridescenceThicknessMaximum", NON_NEGATIVE).with_texture(IRIDESCENCE_THICKNESS_TEXTURE, "G"),
    /// opacity (used in MASK and BLEND modes)
    number!(alpha, Alpha, BASE_COLOR_FACTOR, UNIT).with_part(Part::Alpha).with_texture(BASE_COLOR_TEXTURE, "A"),
    /// OPAQUE ignores alpha, MASK cuts at alphaCutoff, BLEND lets 1 - alpha through
    Param::new("alpha_mode", Section::Alpha, "alphaMode", Kind::Choice(ALPHA_MODES), Field { get: alpha_mode, set: set_alpha_mode }),
    /// alpha below which a MASK material is cut away
    Param::new("alpha_cutoff", Section::Alpha, "alphaCutoff", NON_NEGATIVE, Field { get: alpha_cutoff, set: set_alpha_cutoff }).when(is_mask),
    /// whether the back side is seen (otherwise rays pass through it)
    field!(Material, Switch, switch, double_sided, Alpha, "doubleSided", Kind::Switch).with_gltf_default(ParamValue::Switch(false)),
};

/// A material's alphaMode.
fn alpha_mode(m: &Material) -> ParamValue {
    ParamValue::Choice(match m.alpha_mode {
        AlphaMode::Opaque => "OPAQUE",
        AlphaMode::Mask(_) => "MASK",
        AlphaMode::Blend => "BLEND",
    })
}

/// Sets a material's alphaMode, keeping its cutoff in MASK mode (0.5, glTF's default, if it
/// had none).
fn set_alpha_mode(m: &mut Material, v: ParamValue) {
    m.alpha_mode = match (v, m.alpha_mode) {
        (ParamValue::Choice("MASK"), AlphaMode::Mask(c)) => AlphaMode::Mask(c),
        (ParamValue::Choice("MASK"), _) => AlphaMode::Mask(0.5),
        (ParamValue::Choice("BLEND"), _) => AlphaMode::Blend,
        _ => AlphaMode::Opaque,
    }
}

/// A material's alphaCutoff (glTF's default, 0.5, outside MASK mode).
fn alpha_cutoff(m: &Material) -> ParamValue {
    ParamValue::Number(if let AlphaMode::Mask(c) = m.alpha_mode { c } else { 0.5 })
}

/// Sets a material's alphaCutoff (and so MASK mode).
fn set_alpha_cutoff(m: &mut Material, v: ParamValue) {
    m.alpha_mode = AlphaMode::Mask(v.number());
}

/// Whether a material has a normal map.
fn has_normal_map(m: &Material) -> bool {
    m.normal_tex.is_some()
}

/// Whether a material's clear coat has a normal map.
fn has_clearcoat_normal_map(m: &Material) -> bool {
    m.clearcoat_normal_tex.is_some()
}

/// Whether a material is in MASK mode.
fn is_mask(m: &Material) -> bool {
    matches!(m.alpha_mode, AlphaMode::Mask(_))
}

/// A spot light's cone (a default one for other lights).
fn spot(l: &PunctualLight) -> Cone {
    match l.kind {
        PunctualKind::Spot(cone) => cone,
        _ => Cone::new(0.0, std::f32::consts::FRAC_PI_4),
    }
}

/// Whether a light is a spot light.
fn is_spot(l: &PunctualLight) -> bool {
    matches!(l.kind, PunctualKind::Spot(_))
}

/// A light's direction.
fn direction(l: &PunctualLight) -> ParamValue {
    ParamValue::Triple(l.direction)
}

/// Sets a light's direction, made a unit vector.
fn set_direction(l: &mut PunctualLight, v: ParamValue) {
    l.direction = v.triple().normalize();
}

/// A spot light's inner cone angle.
fn inner_cone(l: &PunctualLight) -> ParamValue {
    ParamValue::Number(spot(l).inner())
}

/// Sets a spot light's inner cone angle.
fn set_inner_cone(l: &mut PunctualLight, v: ParamValue) {
    l.kind = PunctualKind::Spot(Cone::new(v.number(), spot(l).outer()));
}

/// A spot light's outer cone angle.
fn outer_cone(l: &PunctualLight) -> ParamValue {
    ParamValue::Number(spot(l).outer())
}

/// Sets a spot light's outer cone angle.
fn set_outer_cone(l: &mut PunctualLight, v: ParamValue) {
    l.kind = PunctualKind::Spot(Cone::new(spot(l).inner(), v.number()));
}

/// A spot light's inner cone angle: 0 to a right angle.
const INNER_CONE: Kind = Kind::Number { min: 0.0, max: std::f32::consts::FRAC_PI_2 };
/// A spot light's outer cone angle: above 0, up to a right angle.
const OUTER_CONE: Kind = Kind::Number { min: f32::MIN_POSITIVE, max: std::f32::consts::FRAC_PI_2 };

/// Every punctual-light parameter the loader reads.
pub static LIGHT_PARAMS: &[Param<PunctualLight>] = table! {
    /// linear RGB colour
    field!(PunctualLight, Triple, triple, color, Light, "color", UNIT_COLOUR),
    /// candela for point and spot lights, lux for directional ones
    field!(PunctualLight, Number, number, intensity, Light, "intensity", NON_NEGATIVE),
    /// where the light is, in the scene's coordinates (written to its node)
    field!(PunctualLight, Triple, triple, position, Light, "translation", Kind::Position).with_part(Part::Node).when(|l| l.kind != PunctualKind::Directional),
    /// the direction the light shines along, in the scene's coordinates (its node's -z)
    Param::new("direction", Section::Light, "rotation", Kind::Direction, Field { get: direction, set: set_direction }).with_part(Part::Node).when(|l| l.kind != PunctualKind::Point),
    /// angle from the axis within which a spot light is at full intensity (radians)
    Param::new("inner_cone_angle", Section::Light, "spot.innerConeAngle", INNER_CONE, Field { get: inner_cone, set: set_inner_cone }).when(is_spot),
    /// angle from the axis beyond which a spot light gives no light (radians)
    Param::new("outer_cone_angle", Section::Light, "spot.outerConeAngle", OUTER_CONE, Field { get: outer_cone, set: set_outer_cone }).when(is_spot),
};

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
                clearcoat_normal_tex: Some(TexRef::plain(0)),
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
    fn every_parameter_has_its_own_key_and_place_in_a_section_the_editor_shows() {
        for (i, p) in MATERIAL_PARAMS.iter().enumerate() {
            assert!(Section::MATERIAL.contains(&p.section), "{}: its section is shown", p.key);
            let same =
                |q: &Param<Material>| q.key == p.key || (q.section, q.path, q.part) == (p.section, p.path, p.part);
            assert!(!MATERIAL_PARAMS[..i].iter().any(same), "{} twice", p.key);
            assert!(!p.help.is_empty() && !p.help.starts_with(' '), "{}: {:?}", p.key, p.help);
        }
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
