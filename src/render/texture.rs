//! Surface textures: constant values or (u, v) checkerboards.
use glam::{Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub enum Texture<T> {
    Constant(T),
    /// `scale` squares per unit of u and of v.
    Checker {
        even: T,
        odd: T,
        scale: f32,
    },
}

pub type ColorTexture = Texture<Vec3>;
pub type ScalarTexture = Texture<f32>;

impl<T: Copy> Texture<T> {
    #[inline]
    pub fn eval(&self, uv: Vec2) -> T {
        match self {
            Texture::Constant(v) => *v,
            Texture::Checker { even, odd, scale } => {
                let cell = (uv.x * scale).floor() as i64 + (uv.y * scale).floor() as i64;
                if cell.rem_euclid(2) == 0 {
                    *even
                } else {
                    *odd
                }
            }
        }
    }

    /// Every value the texture can take.
    pub fn values(&self) -> Vec<T> {
        match self {
            Texture::Constant(v) => vec![*v],
            Texture::Checker { even, odd, .. } => vec![*even, *odd],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checker_alternates_and_handles_negative_coordinates() {
        let t = Texture::Checker { even: 1.0f32, odd: 2.0, scale: 2.0 };
        assert_eq!(t.eval(Vec2::new(0.1, 0.1)), 1.0);
        assert_eq!(t.eval(Vec2::new(0.6, 0.1)), 2.0);
        assert_eq!(t.eval(Vec2::new(0.6, 0.6)), 1.0);
        assert_eq!(t.eval(Vec2::new(-0.1, 0.1)), 2.0);
        assert_eq!(Texture::Constant(3.0f32).eval(Vec2::new(5.0, 5.0)), 3.0);
    }
}
