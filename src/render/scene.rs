//! The compiled scene the tracer reads: triangles in BVH order, materials, lights, camera.
#[derive(Debug)]
pub struct Scene {
    pub width: u32,
    pub height: u32,
    pub triangle_count: usize,
}
