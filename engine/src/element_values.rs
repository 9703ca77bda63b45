//! Per-element micro values (MatDEM's `d.mo.aKN(ids) = …`, `aKS`, `aXb`, `aFS0`, `aMUp`),
//! written from whole arrays without a per-element lane in the step.
//!
//! Elements carry a material index, and the plan combines each pair of materials once (an
//! M×M table, `plan::pair_params`). A value set on some elements is *copy-on-write*: their
//! material is cloned with the new value (`rock~3`) and they are moved to the clone; a clone
//! with exactly the same values is reused, and clones left without elements are dropped. So
//! the contact pass reads the same table as before, and a scene pays nothing per step for
//! per-element values: the cost is the table, M² pairs. [`MAX_MATERIALS`] bounds it; beyond,
//! a write is refused with the advice to bin the values (a Weibull field in 32 classes
//! reproduces the strength distribution far within a packing's own scatter).
//!
//! Pair values follow from the two elements' values as for two materials: springs in series
//! (each element carries twice its Kn and Ks, so equal values give them back), the smaller
//! breaking displacement times the pair's Kn, the smaller Fs0, the smaller μp.

use crate::error::{Error, Result};
pub use crate::materials::MAX_MATERIALS;
use crate::materials::{base_name, clone_parts, Material, CLONE_MARK};
use crate::model::Model;
use crate::provenance::Source;
use std::collections::{HashMap, HashSet};
use std::str::FromStr;

/// A micro value an element carries through its material.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ElementValue {
    /// Normal spring between two elements of this value (N/m), > 0.
    Kn,
    /// Shear spring (N/m), ≥ 0.
    Ks,
    /// Breaking displacement in tension (m), ≥ 0.
    Xb,
    /// Initial shear resistance of a bond (N), ≥ 0.
    Fs0,
    /// Inter-particle friction coefficient, ≥ 0.
    MuP,
}

impl ElementValue {
    pub const ALL: [ElementValue; 5] =
        [ElementValue::Kn, ElementValue::Ks, ElementValue::Xb, ElementValue::Fs0, ElementValue::MuP];

    /// The script name (the field of `material_micro`).
    pub const fn name(self) -> &'static str {
        match self {
            ElementValue::Kn => "kn",
            ElementValue::Ks => "ks",
            ElementValue::Xb => "xb",
            ElementValue::Fs0 => "fs0",
            ElementValue::MuP => "mu_p",
        }
    }

    const fn unit(self) -> &'static str {
        match self {
            ElementValue::Kn | ElementValue::Ks => "N/m",
            ElementValue::Xb => "m",
            ElementValue::Fs0 => "N",
            ElementValue::MuP => "",
        }
    }

    pub fn of(self, m: &Material) -> f64 {
        match self {
            ElementValue::Kn => m.kn,
            ElementValue::Ks => m.ks,
            ElementValue::Xb => m.xb,
            ElementValue::Fs0 => m.fs0,
            ElementValue::MuP => m.mu_p,
        }
    }

    fn set(self, m: &mut Material, v: f64) {
        match self {
            ElementValue::Kn => m.kn = v,
            ElementValue::Ks => m.ks = v,
            ElementValue::Xb => m.xb = v,
            ElementValue::Fs0 => m.fs0 = v,
            ElementValue::MuP => m.mu_p = v,
        }
    }

    /// Whether `v` is a value this quantity may take: finite, ≥ 0, and > 0 for Kn.
    fn accepts(self, v: f64) -> bool {
        v.is_finite() && (v > 0.0 || (v == 0.0 && self != ElementValue::Kn))
    }
}

impl FromStr for ElementValue {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        ElementValue::ALL
            .into_iter()
            .find(|v| v.name() == s)
            .ok_or_else(|| Error::unknown("per-element value", s, &ElementValue::ALL.map(|v| v.name())))
    }
}

/// Whether two materials are the same apart from their names' clone numbers and provenance.
fn same_values(a: &Material, b: &Material) -> bool {
    let nums = |m: &Material| {
        [m.density, m.kn, m.ks, m.xb, m.fs0, m.mu_p, m.young, m.poisson, m.restitution].map(f64::to_bits)
    };
    base_name(&a.name) == base_name(&b.name) && nums(a) == nums(b)
}

/// The refusal of a write that needs `count` materials.
fn too_many(name: &str, count: String) -> Error {
    Error::InvalidScene(format!(
        "{name}: these values would need {count} materials, and a scene may have at most {MAX_MATERIALS} (the contact \
         pass reads an M×M table of pair constants); bin the values into fewer classes (e.g. a Weibull field into \
         32: (v / step).round() * step); nothing was changed"
    ))
}

impl Model {
    /// Each element's `which` value, from its material.
    pub fn element_values(&self, which: ElementValue) -> Vec<f64> {
        self.particles.material.iter().map(|&k| which.of(&self.materials[k as usize])).collect()
    }

    /// Sets `which` to `values[k]` on element `ids[k]` (MatDEM `d.mo.aKN(ids) = v`) by
    /// copy-on-write of their materials. Every id and value is checked first: a bad id, a
    /// length mismatch, a non-finite or negative value (or Kn ≤ 0), or more materials than
    /// [`MAX_MATERIALS`] is refused naming the element, and nothing changes. Returns the
    /// number of materials the model has afterwards.
    pub fn set_element_values(&mut self, which: ElementValue, ids: &[u32], values: &[f64]) -> Result<usize> {
        self.check_ids(ids)?;
        let name = which.name();
        if ids.len() != values.len() {
            return Err(Error::InvalidScene(format!(
                "{name}: {} elements but {} values; give one value per element; nothing was changed",
                ids.len(),
                values.len()
            )));
        }
        if let Some(k) = values.iter().position(|&v| !which.accepts(v)) {
            let need = if which == ElementValue::Kn { "a finite number > 0" } else { "a finite number ≥ 0" };
            return Err(Error::InvalidScene(format!(
                "{name}: element {} (value {k}) would get {name} = {}; each value must be {need} {}; nothing was \
                 changed",
                ids[k],
                values[k],
                which.unit()
            )));
        }
        // The material each element ends on: its own when the value is already there, else a
        // clone (one per (material, value)), reusing a material with the very same values.
        let mut materials = self.materials.clone();
        let mut assign = self.particles.material.clone();
        let mut made: HashMap<(u32, u64), u32> = HashMap::new();
        let mut names: HashSet<String> = materials.iter().map(|m| m.name.clone()).collect();
        let mut new_clones = 0usize;
        for (&i, &v) in ids.iter().zip(values) {
            // From the element's material before this write (an id given twice: the last wins).
            let old = self.particles.material[i as usize];
            let source = &self.materials[old as usize];
            if which.of(source).to_bits() == v.to_bits() {
                assign[i as usize] = old;
                continue;
            }
            let k = match made.get(&(old, v.to_bits())) {
                Some(&k) => k,
                None => {
                    let mut clone = source.clone();
                    which.set(&mut clone, v);
                    let k = match materials.iter().position(|m| same_values(m, &clone)) {
                        Some(k) => k as u32,
                        None => {
                            // Every clone made here has elements, so more than the limit can
                            // never fit, whatever the write frees: stop before the work grows.
                            new_clones += 1;
                            if new_clones > MAX_MATERIALS {
                                return Err(too_many(name, format!("more than {MAX_MATERIALS}")));
                            }
                            let base = base_name(&source.name);
                            let mut n = 1;
                            while names.contains(&format!("{base}{CLONE_MARK}{n}")) {
                                n += 1;
                            }
                            clone.name = format!("{base}{CLONE_MARK}{n}");
                            names.insert(clone.name.clone());
                            clone.provenance.set(name, Source::Given);
                            materials.push(clone);
                            (materials.len() - 1) as u32
                        }
                    };
                    made.insert((old, v.to_bits()), k);
                    k
                }
            };
            assign[i as usize] = k;
        }
        // Clones no element uses any more go (their numbers are free again); named
        // materials stay, whether used or not, for scripts refer to them by name.
        let mut used = vec![false; materials.len()];
        for &k in &assign {
            used[k as usize] = true;
        }
        let mut renumber = vec![u32::MAX; materials.len()];
        let mut kept = Vec::with_capacity(materials.len());
        for (k, m) in materials.into_iter().enumerate() {
            if used[k] || clone_parts(&m.name).is_none() {
                renumber[k] = kept.len() as u32;
                kept.push(m);
            }
        }
        if kept.len() > MAX_MATERIALS {
            return Err(too_many(name, kept.len().to_string()));
        }
        for k in &mut assign {
            *k = renumber[*k as usize];
        }
        self.materials = kept;
        self.particles.material = assign;
        // Mass follows density, which a clone keeps: nothing else to update.
        self.touch();
        Ok(self.materials.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec3;

    fn model(n: usize) -> Model {
        let mut m = Model::new();
        m.add_material(Material::from_micro("rock", 2650.0, 1e6, 4e5, 1e-6, 10.0, 0.3, 1e-3).unwrap()).unwrap();
        for i in 0..n {
            m.add_particle(Vec3::new(i as f64 * 2e-3, 0.0, 0.0), 1e-3, 0).unwrap();
        }
        m
    }

    #[test]
    fn a_write_clones_once_per_value_reuses_equal_clones_and_drops_unused_ones() {
        let mut m = model(6);
        m.set_element_values(ElementValue::Xb, &[0, 1, 2], &[2e-6, 2e-6, 3e-6]).unwrap();
        let names: Vec<&str> = m.materials.iter().map(|x| x.name.as_str()).collect();
        assert_eq!(names, ["rock", "rock~1", "rock~2"]);
        assert_eq!(m.particles.material, [1, 1, 2, 0, 0, 0]);
        // The same value again is the same clone; a Kn write on a clone clones the clone.
        m.set_element_values(ElementValue::Xb, &[3], &[2e-6]).unwrap();
        assert_eq!(m.particles.material[3], 1);
        m.set_element_values(ElementValue::Kn, &[2], &[2e6]).unwrap();
        // rock~2 lost its only element and went.
        let names: Vec<&str> = m.materials.iter().map(|x| x.name.as_str()).collect();
        assert_eq!(names, ["rock", "rock~1", "rock~3"]);
        assert_eq!((m.materials[2].kn, m.materials[2].xb), (2e6, 3e-6));
        assert_eq!(m.element_values(ElementValue::Xb), [2e-6, 2e-6, 3e-6, 2e-6, 1e-6, 1e-6]);
        // Back to the base value: the base material again, clones dropped.
        m.set_element_values(ElementValue::Xb, &[0, 1, 3], &[1e-6; 3]).unwrap();
        m.set_element_values(ElementValue::Kn, &[2], &[1e6]).unwrap();
        m.set_element_values(ElementValue::Xb, &[2], &[1e-6]).unwrap();
        assert_eq!(m.materials.len(), 1);
        assert_eq!(m.particles.material, [0; 6]);
    }

    #[test]
    fn a_bad_value_or_too_many_materials_is_refused_and_changes_nothing() {
        let mut m = model(300);
        let before = (m.materials.clone(), m.particles.material.clone());
        let e = m.set_element_values(ElementValue::Kn, &[4, 5], &[1e6, 0.0]).unwrap_err().to_string();
        assert!(e.contains("element 5 (value 1)") && e.contains("kn"), "{e}");
        let e = m.set_element_values(ElementValue::MuP, &[4], &[f64::NAN]).unwrap_err().to_string();
        assert!(e.contains("element 4 (value 0)"), "{e}");
        let e = m.set_element_values(ElementValue::Ks, &[4], &[1.0, 2.0]).unwrap_err().to_string();
        assert!(e.contains("1 elements but 2 values"), "{e}");
        let ids: Vec<u32> = (0..300).collect();
        let values: Vec<f64> = (0..300).map(|i| 1e5 + i as f64).collect();
        let e = m.set_element_values(ElementValue::Kn, &ids, &values).unwrap_err().to_string();
        assert!(e.contains("more than 256 materials") && e.contains("at most 256"), "{e}");
        assert_eq!((m.materials.clone(), m.particles.material.clone()), before);
        assert!("kx".parse::<ElementValue>().unwrap_err().to_string().contains("kn"));
    }
}
