//! The fabric tensor of a region's contact normals (Satake 1982; Oda 1982),
//! F = (1/N_c)·Σ_c n ⊗ n, its principal values and directions, and the region's coordination
//! number.
//!
//! Which contacts belong to a region: a contact counts once for each of its two elements
//! whose centre lies in the region (twice when both do, once when it crosses the region's
//! boundary). So F is the mean over the region's elements of each element's own contact
//! fabric, and the coordination number is the mean number of contacts of an element whose
//! centre is inside: for a perfect FCC lattice, I/3 and 12 in any region that holds only
//! interior elements. Contacts are the touching pairs and intact bonds between elements;
//! wall contacts and broken bonds that have come apart are left out, as in
//! `status::contact_stats`.

use super::contact_list::ContactList;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::physics::Vec3;
use crate::status::Region;
use nalgebra::{Matrix3, SymmetricEigen};

/// A region's fabric.
#[derive(Debug, Clone, PartialEq)]
pub struct Fabric {
    /// (1/N_c)·Σ n ⊗ n (trace 1).
    pub tensor: Matrix3<f64>,
    /// Principal values, largest first (they sum to 1).
    pub values: [f64; 3],
    /// Unit principal directions, in the order of `values` (each with its largest component
    /// positive, so that the sign is fixed).
    pub directions: [Vec3; 3],
    /// Contacts counted, each by the number of its elements inside (N_c above).
    pub contacts: f64,
    /// Elements whose centre lies in the region (killed elements left out).
    pub elements: usize,
    /// Mean contacts per element inside: contacts / elements.
    pub coordination: f64,
}

/// The fabric of the contacts of `list` in `region` (the whole model when `None`).
pub fn fabric(m: &Model, list: &ContactList, region: Option<&Region>) -> Result<Fabric> {
    let inside = elements_inside(m, region);
    let elements = inside.iter().filter(|b| **b).count();
    if elements == 0 {
        return Err(Error::InvalidScene(
            "fabric: no element has its centre in the region; enlarge it or move it into the packing".into(),
        ));
    }
    let mut sum = Matrix3::zeros();
    let mut contacts = 0.0;
    for row in list.rows.iter().filter(|r| r.is_active()) {
        let Some(j) = row.j() else { continue };
        let w = f64::from(u8::from(inside[row.i as usize]) + u8::from(inside[j as usize]));
        if w > 0.0 {
            sum += row.normal * row.normal.transpose() * w;
            contacts += w;
        }
    }
    if contacts == 0.0 {
        return Err(Error::InvalidScene(format!(
            "fabric: the {elements} element(s) in the region touch nothing, so there is no contact normal to average"
        )));
    }
    let tensor = sum / contacts;
    let (values, directions) = principal(&tensor);
    Ok(Fabric { tensor, values, directions, contacts, elements, coordination: contacts / elements as f64 })
}

/// Which elements have their centre in `region` (every live one when `None`).
pub(super) fn elements_inside(m: &Model, region: Option<&Region>) -> Vec<bool> {
    let p = &m.particles;
    (0..p.len()).map(|i| !m.is_killed(i) && region.is_none_or(|r| r.contains(&p.pos[i]))).collect()
}

/// Principal values (largest first) and unit directions of a symmetric tensor, each direction
/// with its largest component positive.
pub fn principal(t: &Matrix3<f64>) -> ([f64; 3], [Vec3; 3]) {
    let eig = SymmetricEigen::new(*t);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let values = order.map(|k| eig.eigenvalues[k]);
    let directions = order.map(|k| {
        let v: Vec3 = eig.eigenvectors.column(k).into();
        let big = (0..3).max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs())).unwrap_or(0);
        if v[big] < 0.0 {
            -v
        } else {
            v
        }
    });
    (values, directions)
}
