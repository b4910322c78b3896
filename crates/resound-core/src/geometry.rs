//! Small geometric helpers on triangle meshes shared by several crates.

/// 3-vector difference a − b.
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Dot product.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Euclidean norm.
pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Axis-aligned bounding box (min, max) of points; zeros when there are none.
pub fn bbox(points: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    if points.is_empty() {
        return ([0.0; 3], [0.0; 3]);
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for v in points {
        for c in 0..3 {
            lo[c] = lo[c].min(v[c]);
            hi[c] = hi[c].max(v[c]);
        }
    }
    (lo, hi)
}

/// Closest point on triangle (a, b, c) to p, as barycentric weights (wa, wb, wc).
///
/// Region-based method (Ericson, *Real-Time Collision Detection*, §5.1.5).
pub fn closest_point_on_triangle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    [1.0 - v - w, v, w]
}

/// The closest point of a triangle mesh to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Triangle index.
    pub triangle: usize,
    /// Barycentric weights of the triangle's three vertices.
    pub bary: [f64; 3],
    /// The point on the surface (m).
    pub point: [f64; 3],
    /// Unit outward normal of the triangle (for a consistently outward-oriented mesh).
    pub normal: [f64; 3],
    /// Distance from the query to the surface point (m).
    pub distance: f64,
}

/// Closest point on a triangle mesh (brute force over all triangles; meshes here have at most
/// a few 10⁵ triangles and this is called once per hit point). `None` for an empty mesh.
pub fn closest_surface_point(
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    p: [f64; 3],
) -> Option<SurfacePoint> {
    let mut best: Option<SurfacePoint> = None;
    for (t, tri) in triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|i| vertices[i as usize]);
        let w = closest_point_on_triangle(p, a, b, c);
        let q = [0, 1, 2].map(|k| w[0] * a[k] + w[1] * b[k] + w[2] * c[k]);
        let d = norm(sub(p, q));
        if best.is_none_or(|bst| d < bst.distance) {
            let n = cross(sub(b, a), sub(c, a));
            let len = norm(n);
            let normal = if len > 0.0 {
                n.map(|x| x / len)
            } else {
                [0.0; 3]
            };
            best = Some(SurfacePoint {
                triangle: t,
                bary: w,
                point: q,
                normal,
                distance: d,
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        // Above the interior: projects straight down.
        let w = closest_point_on_triangle([0.25, 0.25, 3.0], a, b, c);
        assert!((w[0] - 0.5).abs() < 1e-12 && (w[1] - 0.25).abs() < 1e-12);
        // Beyond vertex b.
        assert_eq!(
            closest_point_on_triangle([2.0, -1.0, 0.0], a, b, c),
            [0.0, 1.0, 0.0]
        );
        // Beyond edge bc.
        let w = closest_point_on_triangle([1.0, 1.0, 0.0], a, b, c);
        assert!((w[1] - 0.5).abs() < 1e-12 && (w[2] - 0.5).abs() < 1e-12);
    }
}
