//! Clumps made from a template: each element of a packing replaced by a clump of the
//! template's spheres inside its own sphere, turned at random (MatDEM's and PFC's way to deposit
//! clumps: balls first, then clumps in their place).

use crate::error::{Error, Result};
use crate::model::Model;
use crate::physics::Vec3;

impl Model {
    /// Replaces each element of `ids` by a clump of `template` (spheres `[x, y, z, r]` about the
    /// template's origin, in any unit): scaled so that the template reaches as far from its
    /// origin as the element's radius, turned by a random rotation (uniform over rotations, from
    /// `seed` and the element's place in `ids`: deterministic), centred where the element was,
    /// of its material and velocity, in its groups. MatDEM's and PFC's way to deposit clumps: a
    /// packing of balls is built first, then each ball becomes a clump inside its own sphere.
    /// Returns the new clumps' numbers.
    pub fn replace_with_clumps(&mut self, ids: &[u32], template: &[[f64; 4]], seed: u64) -> Result<Vec<usize>> {
        self.check_ids(ids)?;
        let reach = template.iter().map(|s| Vec3::new(s[0], s[1], s[2]).norm() + s[3]).fold(0.0, f64::max);
        let sound = !template.is_empty()
            && template.iter().all(|s| s.iter().all(|v| v.is_finite()) && s[3] > 0.0)
            && reach > 0.0;
        if !sound {
            return Err(Error::InvalidScene(
                "replace_with_clumps: give a template of spheres [x, y, z, r] with finite centres and radii > 0".into(),
            ));
        }
        if self.settings.planar.is_some() && template.iter().any(|s| s[1] != 0.0) {
            return Err(Error::InvalidScene(
                "replace_with_clumps: the model is 2D (x–z plane); give a template of discs [x, 0, z, r]".into(),
            ));
        }
        let mut ids = ids.to_vec();
        ids.sort_unstable();
        ids.dedup();
        for &i in &ids {
            let held = if self.settings.planar.is_some() { crate::planar::HELD } else { 0 };
            if self.particles.fixed[i as usize] & !held != 0 {
                return Err(Error::InvalidScene(format!(
                    "replace_with_clumps: element {i} is killed, fixed or in a clump; replace free elements"
                )));
            }
        }
        let n0 = self.len();
        let mut rng = crate::builder::Rng::new(seed);
        // Every group each replaced element is in, to put its members in.
        let names: Vec<String> = self.groups.names().map(str::to_string).collect();
        let mut joins: Vec<(String, Vec<u32>)> = names.iter().map(|g| (g.clone(), Vec::new())).collect();
        let mut made = Vec::with_capacity(ids.len());
        for &i in &ids {
            let i = i as usize;
            let (x, r, v, mat) =
                (self.particles.pos[i], self.particles.radius[i], self.particles.vel[i], self.particles.material[i]);
            // A 2D model's clumps turn in its plane only.
            let turn = match self.settings.planar {
                Some(_) => {
                    nalgebra::UnitQuaternion::from_axis_angle(&Vec3::y_axis(), std::f64::consts::TAU * rng.uniform())
                }
                None => random_rotation(&mut rng),
            };
            let scale = r / reach;
            let first = self.len() as u32;
            for s in template {
                let at = x + turn.transform_vector(&Vec3::new(s[0], s[1], s[2])) * scale;
                let j = self.add_particle(at, s[3] * scale, mat)?;
                self.particles.vel[j] = v;
            }
            let members: Vec<u32> = (first..self.len() as u32).collect();
            for (g, (_, list)) in names.iter().zip(&mut joins) {
                if self.groups.get(g).is_ok_and(|ids| ids.binary_search(&(i as u32)).is_ok()) {
                    list.extend(&members);
                }
            }
            made.push(members);
        }
        for (g, list) in joins.into_iter().filter(|(_, l)| !l.is_empty()) {
            let mut all = self.groups.get(&g).map(<[u32]>::to_vec).unwrap_or_default();
            all.extend(list);
            self.groups.set(&g, all);
        }
        self.remove_particles(&ids)?;
        // The new elements came after the n0 old ones, all of the removed among those.
        let shift = ids.len() as u32;
        debug_assert!(made.iter().flatten().all(|&j| j as usize >= n0));
        made.iter().map(|members| self.clump(&members.iter().map(|j| j - shift).collect::<Vec<_>>())).collect()
    }
}

/// A rotation drawn uniformly (Shoemake's three-uniform quaternion).
fn random_rotation(rng: &mut crate::builder::Rng) -> nalgebra::UnitQuaternion<f64> {
    use std::f64::consts::TAU;
    let (u1, u2, u3) = (rng.uniform(), rng.uniform(), rng.uniform());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let q = nalgebra::Quaternion::new(
        b * (TAU * u3).cos(),
        a * (TAU * u2).sin(),
        a * (TAU * u2).cos(),
        b * (TAU * u3).sin(),
    );
    nalgebra::UnitQuaternion::from_quaternion(q)
}
