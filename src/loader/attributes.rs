//! Vertex attributes at every component type glTF 2.0 (3.7.2.1) and KHR_mesh_quantization
//! allow, dequantized to f32 by the spec's normalization equations (glTF 2.0, 3.11), with
//! morph targets applied at their weights (3.7.2.2).

use gltf::Semantic;
use gltf::accessor::{Accessor, DataType as T, Dimensions as D, Item, Iter};
use gltf::buffer::Buffer;

/// The extension that lets positions, normals, tangents and texture coordinates be integers.
pub(super) const QUANTIZATION: &str = "KHR_mesh_quantization";

/// Whether `a` has a type the spec allows for `semantic`; `quantized` when the file uses
/// KHR_mesh_quantization. `Weights(u32::MAX)` stands for the indices.
pub(super) fn allowed(semantic: &Semantic, a: &Accessor, quantized: bool) -> bool {
    let (dims, ty, norm) = (a.dimensions(), a.data_type(), a.normalized());
    let unorm = matches!(ty, T::U8 | T::U16) && norm;
    let snorm = matches!(ty, T::I8 | T::I16) && norm;
    let int = matches!(ty, T::I8 | T::U8 | T::I16 | T::U16);
    match semantic {
        Semantic::Positions => dims == D::Vec3 && (ty == T::F32 || quantized && int),
        Semantic::Normals => dims == D::Vec3 && (ty == T::F32 || quantized && snorm),
        Semantic::Tangents => dims == D::Vec4 && (ty == T::F32 || quantized && snorm),
        Semantic::TexCoords(_) => dims == D::Vec2 && (ty == T::F32 || unorm || quantized && int),
        Semantic::Colors(_) => matches!(dims, D::Vec3 | D::Vec4) && matches!(ty, T::F32 | T::U8 | T::U16),
        Semantic::Weights(u32::MAX) => dims == D::Scalar && matches!(ty, T::U8 | T::U16 | T::U32),
        _ => true,
    }
}

/// The accessor's elements as f32: integers are divided as glTF 2.0's table says when the
/// accessor is normalized (signed ones clamped at -1), and converted as they are when not.
/// None for a component type no attribute may have (u32), or data out of its buffer.
pub(super) fn read<'a, 's, const N: usize>(
    a: &Accessor<'a>,
    get: impl Clone + Fn(Buffer<'a>) -> Option<&'s [u8]>,
) -> Option<Vec<[f32; N]>>
where
    [f32; N]: Item,
    [i8; N]: Item,
    [u8; N]: Item,
    [i16; N]: Item,
    [u16; N]: Item,
{
    fn each<'a, 's, C: Copy, const N: usize>(
        a: &Accessor<'a>,
        get: impl Clone + Fn(Buffer<'a>) -> Option<&'s [u8]>,
        f: impl Fn(C) -> f32,
    ) -> Option<Vec<[f32; N]>>
    where
        [C; N]: Item,
    {
        Some(Iter::<[C; N]>::new(a.clone(), get)?.map(|v| v.map(&f)).collect())
    }
    let norm = a.normalized();
    match a.data_type() {
        T::F32 => each(a, get, |c: f32| c),
        T::I8 => each(a, get, |c: i8| if norm { snorm(c.into(), 127.0) } else { c.into() }),
        T::U8 => each(a, get, |c: u8| if norm { f32::from(c) / 255.0 } else { c.into() }),
        T::I16 => each(a, get, |c: i16| if norm { snorm(c.into(), 32767.0) } else { c.into() }),
        T::U16 => each(a, get, |c: u16| if norm { f32::from(c) / 65535.0 } else { c.into() }),
        T::U32 => None,
    }
}

/// Adds to `base` each morph target's deltas (`targets`, one accessor or none per target)
/// times its weight: the morphed attribute is `base + sum w_i delta_i` (glTF 2.0, 3.7.2.2).
pub(super) fn morph<'a, 's>(
    base: &mut [[f32; 3]],
    targets: impl Iterator<Item = Option<Accessor<'a>>>,
    weights: &[f32],
    get: impl Clone + Fn(Buffer<'a>) -> Option<&'s [u8]>,
) -> Result<(), String> {
    for (target, &w) in targets.zip(weights) {
        let Some(a) = target.filter(|_| w != 0.0) else { continue };
        let deltas = read::<3>(&a, get.clone()).ok_or_else(|| format!("accessor {} cannot be read", a.index()))?;
        for (v, d) in base.iter_mut().zip(deltas) {
            (0..3).for_each(|k| v[k] += w * d[k]);
        }
    }
    Ok(())
}

/// A signed normalized integer as f32: `max(c / max, -1)` (glTF 2.0, 3.11).
fn snorm(c: f32, max: f32) -> f32 {
    (c / max).max(-1.0)
}

#[cfg(test)]
mod tests {
    use super::snorm;

    #[test]
    fn signed_normalized_integers_reach_minus_one_at_both_lowest_codes() {
        assert_eq!(snorm(-128.0, 127.0), -1.0);
        assert_eq!(snorm(-127.0, 127.0), -1.0);
        assert_eq!(snorm(127.0, 127.0), 1.0);
        assert_eq!(snorm(-32768.0, 32767.0), -1.0);
        assert_eq!(snorm(0.0, 32767.0), 0.0);
    }
}
