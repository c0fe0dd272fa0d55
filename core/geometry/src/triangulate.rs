//! Triangles of the Instance Space's polygons, for everything that hands a model to a
//! triangle-only consumer: the display's GPU meshes, glTF and STL export.
//!
//! Every polygon the Instance Space holds is convex and planar (checked by
//! [`crate::Polyhedron::from_polygons`]; the library splits concave input before it gets
//! there), so a fan from the first vertex triangulates it exactly: `n − 2` triangles for `n`
//! vertices, counter-clockwise as the polygon (normals point out of the solid).

/// The fan triangles of one convex polygon given by its vertex indices: `[p0, pk, pk+1]` for
/// k = 1 … n−2. Fewer than three indices give no triangle.
pub fn fan(polygon: &[u32]) -> impl Iterator<Item = [u32; 3]> + '_ {
    (1..polygon.len().saturating_sub(1)).map(move |k| [polygon[0], polygon[k], polygon[k + 1]])
}

/// How many triangles [`fan`] makes of a polygon of `len` vertices.
pub fn fan_count(len: usize) -> usize {
    len.saturating_sub(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pentagon_makes_three_triangles_sharing_its_first_vertex() {
        let t: Vec<[u32; 3]> = fan(&[4, 5, 6, 7, 8]).collect();
        assert_eq!(t, vec![[4, 5, 6], [4, 6, 7], [4, 7, 8]]);
        assert_eq!(fan_count(5), 3);
        assert_eq!(fan(&[1, 2]).count(), 0);
        assert_eq!(fan_count(2), 0);
    }
}
