//! A soft body's material: an isotropic linear elastic solid with density and damping.

/// An isotropic elastic material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Young's modulus, Pa.
    pub young: f64,
    /// Poisson's ratio, in [0, 0.5).
    pub poisson: f64,
    /// Density, kg/m³.
    pub density: f64,
    /// Stiffness-proportional (Rayleigh) damping, s: each mode of angular frequency ω is
    /// damped at the ratio ω·damping/2.
    pub damping: f64,
}

impl Material {
    /// Lamé's first parameter λ, Pa.
    pub fn lambda(&self) -> f64 {
        let (e, nu) = (self.young, self.poisson);
        e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    }

    /// The shear modulus μ, Pa.
    pub fn mu(&self) -> f64 {
        self.young / (2.0 * (1.0 + self.poisson))
    }

    /// The factor s = β·dt + dt² its stiffness weighs in a step of `dt` with (its damping β
    /// and the step's own stiffening).
    pub fn step_factor(&self, dt: f64) -> f64 {
        self.damping * dt + dt * dt
    }

    /// The speed of a pressure wave through it, m/s: how fast a push crosses an element.
    pub fn wave_speed(&self) -> f64 {
        ((self.lambda() + 2.0 * self.mu()) / self.density).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// λ and μ give back E and ν: E = μ(3λ + 2μ)/(λ + μ), ν = λ/(2(λ + μ)).
    #[test]
    fn lame_parameters_give_back_young_s_modulus_and_poisson_s_ratio() {
        for (young, poisson) in [(1e4, 0.0), (2.1e11, 0.3), (5e5, 0.49)] {
            let m = Material {
                young,
                poisson,
                density: 1000.0,
                damping: 0.0,
            };
            let (l, mu) = (m.lambda(), m.mu());
            let e = mu * (3.0 * l + 2.0 * mu) / (l + mu);
            let nu = l / (2.0 * (l + mu));
            assert!((e / young - 1.0).abs() < 1e-12, "{e}");
            assert!((nu - poisson).abs() < 1e-12, "{nu}");
        }
    }
}
