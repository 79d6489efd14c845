//! Which meshes placed many times stay instanced (stored once, traced through the
//! top-level BVH) and which are flattened into world-space copies: a small mesh placed a few
//! times costs little memory flattened, and flattened it is traced without a second level.

use super::{MeshDesc, SceneDesc};
use glam::{Affine3A, Vec4Swizzles};

/// Placed triangles up to which a mesh placed many times is flattened by `Instancing::Auto`:
/// about 22 MB of built scene (`loader::limits::TRIANGLE` bytes each).
pub const FLATTEN_TRIANGLES: u64 = 1 << 16;

/// What to do with meshes placed more than once.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Instancing {
    /// Flatten a mesh whose copies add up to at most `FLATTEN_TRIANGLES` triangles;
    /// instance the others.
    #[default]
    Auto,
    /// Instance every mesh placed more than once.
    Always,
    /// Flatten every mesh into world-space copies (memory follows the placed triangles).
    Never,
}

impl std::str::FromStr for Instancing {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            "always" => Ok(Self::Always),
            "never" => Ok(Self::Never),
            _ => Err(format!("instancing must be auto, always or never, not \"{s}\"")),
        }
    }
}

impl Instancing {
    /// Whether a mesh of `triangles` triangles placed `copies` times is flattened.
    pub fn flattens(self, copies: u64, triangles: u64) -> bool {
        match self {
            Instancing::Auto => copies.saturating_mul(triangles) <= FLATTEN_TRIANGLES,
            Instancing::Always => copies <= 1,
            Instancing::Never => true,
        }
    }
}

impl SceneDesc {
    /// Flattens the instanced meshes `policy` says to flatten, refusing (in one line) to
    /// make more than `max_triangles` triangles that way.
    pub fn apply_instancing(&mut self, policy: Instancing, max_triangles: u64) -> Result<(), String> {
        let flattened = |m: &MeshDesc| {
            let (copies, triangles) = (m.instances.len() as u64, m.indices.len() as u64 / 3);
            (!m.instances.is_empty() && policy.flattens(copies, triangles)).then_some(copies * triangles)
        };
        let total: u64 = self.meshes.iter().filter_map(flattened).sum();
        if total > max_triangles {
            return Err(format!(
                "flattening the instanced meshes would place {total} triangles, over the {max_triangles} the memory limit allows (keep them instanced)"
            ));
        }
        let mut meshes = Vec::with_capacity(self.meshes.len());
        for mesh in std::mem::take(&mut self.meshes) {
            if flattened(&mesh).is_none() {
                meshes.push(mesh);
                continue;
            }
            meshes.extend(mesh.instances.iter().map(|t| placed(&mesh, t)));
        }
        self.meshes = meshes;
        Ok(())
    }
}

/// A world-space copy of `mesh` placed by `t`, as a loader flattens it: normals through the
/// inverse transpose, tangents through the linear part with their handedness flipped, and
/// the winding reversed, by a mirroring transform.
fn placed(mesh: &MeshDesc, t: &Affine3A) -> MeshDesc {
    let normal_matrix = t.matrix3.inverse().transpose();
    let mirrored = t.matrix3.determinant() < 0.0;
    let mut indices = mesh.indices.clone();
    if mirrored {
        indices.chunks_exact_mut(3).for_each(|tri| tri.swap(1, 2));
    }
    let sign = if mirrored { -1.0 } else { 1.0 };
    MeshDesc {
        positions: mesh.positions.iter().map(|&p| t.transform_point3(p)).collect(),
        normals: mesh.normals.as_ref().map(|n| n.iter().map(|&v| (normal_matrix * v).normalize_or_zero()).collect()),
        tangents: mesh
            .tangents
            .as_ref()
            .map(|ts| ts.iter().map(|v| t.transform_vector3(v.xyz()).normalize_or_zero().extend(v.w * sign)).collect()),
        indices,
        instances: Vec::new(),
        ..mesh.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Quat, Vec3, Vec4};

    #[test]
    fn auto_flattens_what_adds_up_to_few_triangles() {
        assert!(Instancing::Auto.flattens(2, 1000));
        assert!(!Instancing::Auto.flattens(20_000, 2_000));
        assert!(!Instancing::Always.flattens(2, 1));
        assert!(Instancing::Never.flattens(20_000, 2_000));
    }

    #[test]
    fn mirrored_copies_keep_their_front_faces_and_tangent_frames() {
        let mesh = MeshDesc {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: Some(vec![Vec3::Z; 3]),
            tangents: Some(vec![Vec4::new(1.0, 0.0, 0.0, 1.0); 3]),
            indices: vec![0, 1, 2],
            instances: vec![
                Affine3A::from_scale(Vec3::new(1.0, 1.0, -1.0)),
                Affine3A::from_quat(Quat::from_rotation_x(1.0)),
            ],
            ..MeshDesc::default()
        };
        let mut desc = SceneDesc { meshes: vec![mesh], ..SceneDesc::default() };
        desc.apply_instancing(Instancing::Never, 10).unwrap();
        let m = &desc.meshes[0];
        assert_eq!(m.indices, vec![0, 2, 1], "winding reversed");
        assert_eq!(m.normals.as_ref().unwrap()[0], -Vec3::Z);
        assert_eq!(m.tangents.as_ref().unwrap()[0].w, -1.0);
        let p = &m.positions;
        let facing = (p[m.indices[1] as usize] - p[0]).cross(p[m.indices[2] as usize] - p[0]);
        assert!(facing.dot(-Vec3::Z) > 0.0, "the front face turns with its normal");
        assert_eq!(desc.meshes.len(), 2);
        let mut too_many = SceneDesc { meshes: desc.meshes.clone(), ..SceneDesc::default() };
        too_many.meshes[0].instances = vec![Affine3A::IDENTITY; 11];
        assert!(too_many.apply_instancing(Instancing::Never, 10).unwrap_err().contains("11 triangles"));
    }
}
