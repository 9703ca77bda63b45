//! The membrane's geometry and load, shared by the CPU pass, the report and (in f32) the WGSL.
//!
//! The side of the sample is cut into cells: `bands` equal bands of the height between the two
//! platens, each cut into `sectors` equal sectors around the axis. In each cell the grain that
//! reaches farthest from the axis (largest ρ + r, ρ its centre's distance from the axis; the
//! lowest id of equals) is the one the membrane touches, and the pressure σ over the cell's
//! patch of membrane, (ρ + r)·Δθ·Δz, pushes it towards the axis:
//!
//! ```text
//! F = −σ·(ρ + r)·Δθ·Δz·e_ρ.
//! ```
//!
//! A cell with no grain centre in it (a random packing's surface leaves some: a surface grain's
//! centre lies in the next cell) is covered by a neighbour's grain: its patch goes to the touched
//! cell beside it whose grain reaches farthest (the sectors either side in its band, then the
//! bands above and below; the first of equals), which then carries `1 + shares` patches. Without
//! it a random sample of one-diameter cells lost 7 % of its side's load.
//!
//! That force is −∇(σ·V) for the grain, V = Σ (1 + shares)·½·(ρ + r)²·Δθ·Δz over the touched
//! cells being the volume the membrane encloses: while no grain changes cell and the platens
//! stand still, the confining fluid is a potential σ·V (`status::Energies::confining`), and the
//! sum of the loads is σ times the membrane's area.
//!
//! A 2D model (a plate of thickness t in the x–z plane: a biaxial test) has two sectors, the
//! sides left and right of the axis; ρ = |x − x_axis|, the patch is t·Δz whatever the reach,
//! F = −σ·t·Δz·e_x outwards-normal, and V = Σ (1 + shares)·(ρ + r)·t·Δz (again F = −∇(σ·V)). An
//! empty cell is covered from the bands above and below on its own side only.

use crate::physics::Vec3;
use crate::state::particles::{dof, Particles};

/// The membrane's cells at one instant (the platens where they are now).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cells {
    pub bands: u32,
    pub sectors: u32,
    pub axis: [f64; 2],
    /// The bottom platen's height and a band's height (m).
    pub z0: f64,
    pub dz: f64,
    /// A sector's angle (rad).
    pub dtheta: f64,
    /// A 2D model's plate thickness (m): two sectors, the sides (`None` in 3D).
    pub thickness: Option<f64>,
}

/// Where a grain sits against the membrane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Place {
    pub cell: usize,
    /// ρ + r: how far the grain reaches from the axis (m).
    pub reach: f64,
    /// The unit vector from the axis to the centre, across the axis (zero on the axis).
    pub out: [f64; 2],
}

impl Cells {
    /// The cells between platens at heights `z0` < `z1`.
    pub fn new(bands: u32, sectors: u32, axis: [f64; 2], z0: f64, z1: f64) -> Self {
        Cells {
            bands,
            sectors,
            axis,
            z0,
            dz: (z1 - z0) / f64::from(bands),
            dtheta: std::f64::consts::TAU / f64::from(sectors),
            thickness: None,
        }
    }

    /// A 2D model's cells: `bands` on each side of the axis x = `axis_x`, the plate `thickness`
    /// thick.
    pub fn planar(bands: u32, axis_x: f64, z0: f64, z1: f64, thickness: f64) -> Self {
        Cells { thickness: Some(thickness), ..Cells::new(bands, 2, [axis_x, 0.0], z0, z1) }
    }

    pub fn count(&self) -> usize {
        self.bands as usize * self.sectors as usize
    }

    /// The cell of a grain at `pos` with radius `r`: grains beyond a platen count in the band
    /// next to it.
    pub fn place(&self, pos: &Vec3, r: f64) -> Place {
        let band_of = |z: f64| (((z - self.z0) / self.dz).floor().max(0.0) as u32).min(self.bands - 1);
        if self.thickness.is_some() {
            // Sector 0 left of the axis, 1 right of it (on it: right, pushed nowhere).
            let dx = pos.x - self.axis[0];
            let sector = u32::from(dx >= 0.0);
            let out = [
                if dx > 0.0 {
                    1.0
                } else if dx < 0.0 {
                    -1.0
                } else {
                    0.0
                },
                0.0,
            ];
            return Place { cell: (band_of(pos.z) * 2 + sector) as usize, reach: dx.abs() + r, out };
        }
        let (dx, dy) = (pos.x - self.axis[0], pos.y - self.axis[1]);
        // Not `hypot`: its care for overflow costs more than the rest of the placing, and a
        // sample's coordinates are far from overflowing a square.
        let rho = (dx * dx + dy * dy).sqrt();
        let band = band_of(pos.z);
        let theta = dy.atan2(dx) + std::f64::consts::PI;
        let sector = ((theta / self.dtheta).floor().max(0.0) as u32).min(self.sectors - 1);
        let out = if rho > 0.0 { [dx / rho, dy / rho] } else { [0.0, 0.0] };
        Place { cell: (band * self.sectors + sector) as usize, reach: rho + r, out }
    }

    /// The membrane's patch over a grain that reaches `reach` from the axis (m²).
    pub fn patch(&self, reach: f64) -> f64 {
        match self.thickness {
            Some(t) => t * self.dz,
            None => reach * self.dtheta * self.dz,
        }
    }

    /// The membrane's load on the grain at `place` under pressure `pressure`, its cell carrying
    /// `shares` empty neighbours' patches besides its own (N).
    pub fn load(&self, pressure: f64, place: &Place, shares: u32) -> Vec3 {
        let f = -pressure * self.patch(place.reach) * f64::from(1 + shares);
        Vec3::new(f * place.out[0], f * place.out[1], 0.0)
    }

    /// The cells that may cover `cell` when it is empty, in the order of preference among
    /// equals: the sectors before and after it in its band (around the axis), then the bands
    /// below and above it in its sector.
    pub fn beside(&self, cell: usize) -> impl Iterator<Item = usize> {
        let (s, b) = (self.sectors as usize, self.bands as usize);
        let (band, sector) = (cell / s, cell % s);
        // A 2D model's two sides do not touch.
        let around = self.thickness.is_none();
        [
            (around && s > 1).then(|| band * s + (sector + s - 1) % s),
            (around && s > 2).then(|| band * s + (sector + 1) % s),
            (band > 0).then(|| cell - s),
            (band + 1 < b).then(|| cell + s),
        ]
        .into_iter()
        .flatten()
    }

    /// The volume a cell's patch encloses over a grain reaching `reach` (m³).
    pub fn volume(&self, reach: f64) -> f64 {
        match self.thickness {
            Some(t) => reach * t * self.dz,
            None => 0.5 * reach * reach * self.dtheta * self.dz,
        }
    }

    /// The membrane's whole side at a mean reach `radius` (m²): the cylinder's 2π·R·H, or a 2D
    /// plate's two sides 2·t·H.
    pub fn side(&self, radius: f64) -> f64 {
        let height = self.dz * f64::from(self.bands);
        match self.thickness {
            Some(t) => 2.0 * t * height,
            None => std::f64::consts::TAU * radius * height,
        }
    }
}

/// A grain the membrane touches: its cell and id.
pub const NONE: u32 = u32::MAX;

/// Each cell's outermost grain (`NONE` for an empty cell) and its reach, for grains at `pos` with
/// radii `radius`, `skip(i)` true for grains out of the model. The grains are placed in parallel
/// (an `atan2` each: serially and with `hypot`, the pass took 11 ms a step of 108,000 grains on
/// 2 cores, now 3.5), then compared in one serial pass in id order: a tie goes to the lowest id,
/// whatever the thread count.
pub fn outermost(cells: &Cells, pos: &[Vec3], radius: &[f64], skip: impl Fn(usize) -> bool + Sync) -> Vec<(u32, f64)> {
    use rayon::prelude::*;
    let mut places: Vec<Option<(usize, f64)>> = Vec::new();
    (0..pos.len())
        .into_par_iter()
        .with_min_len(4096)
        .map(|i| {
            (!skip(i)).then(|| {
                let p = cells.place(&pos[i], radius[i]);
                (p.cell, p.reach)
            })
        })
        .collect_into_vec(&mut places);
    let mut best = vec![(NONE, 0.0); cells.count()];
    for (i, &(cell, reach)) in places.iter().enumerate().filter_map(|(i, p)| p.as_ref().map(|p| (i, p))) {
        let b = &mut best[cell];
        if b.0 == NONE || reach > b.1 {
            *b = (i as u32, reach);
        }
    }
    best
}

/// For each cell, how many empty cells' patches it carries besides its own: each empty cell's
/// goes to the touched cell beside it whose grain reaches farthest (the first of equals in
/// [`Cells::beside`]'s order); an empty cell with no touched cell beside it is lost.
pub fn shares(cells: &Cells, best: &[(u32, f64)]) -> Vec<u32> {
    let mut shares = vec![0u32; best.len()];
    for c in (0..best.len()).filter(|&c| best[c].0 == NONE) {
        let mut to: Option<usize> = None;
        for n in cells.beside(c).filter(|&n| best[n].0 != NONE) {
            if to.is_none_or(|t| best[n].1 > best[t].1) {
                to = Some(n);
            }
        }
        if let Some(t) = to {
            shares[t] += 1;
        }
    }
    shares
}

/// The membrane's picks for the particles as they stand: each cell's outermost grain and reach
/// ([`outermost`], killed elements out of the model) and each cell's shares ([`shares`]). The
/// CPU pass, the report and the potential all start here.
pub fn picks(cells: &Cells, p: &Particles) -> (Vec<(u32, f64)>, Vec<u32>) {
    let best = outermost(cells, &p.pos, &p.radius, |i| p.fixed[i] & dof::KILLED != 0);
    let shares = shares(cells, &best);
    (best, shares)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grain_is_placed_in_its_band_and_sector_and_pushed_towards_the_axis() {
        let c = Cells::new(4, 8, [1.0, 2.0], 0.0, 0.4);
        // 0.3 m from the axis along +y, at z = 0.25: band 2; θ = π/2 + π = 3π/2, sector 6.
        let p = c.place(&Vec3::new(1.0, 2.3, 0.25), 0.05);
        assert_eq!(p.cell, 2 * 8 + 6);
        assert!((p.reach - 0.35).abs() < 1e-15);
        let f = c.load(1e5, &p, 0);
        let expect = 1e5 * 0.35 * (std::f64::consts::TAU / 8.0) * 0.1;
        assert!(f.x.abs() < 1e-9 && (f.y + expect).abs() < 1e-9 * expect && f.z == 0.0, "{f:?}");
        // Beyond the platens: the end bands.
        assert_eq!(c.place(&Vec3::new(1.3, 2.0, -0.1), 0.01).cell / 8, 0);
        assert_eq!(c.place(&Vec3::new(1.3, 2.0, 0.9), 0.01).cell / 8, 3);
    }

    #[test]
    fn the_load_is_minus_the_gradient_of_pressure_times_volume() {
        let c = Cells::new(3, 12, [0.0, 0.0], 0.0, 0.3);
        let (x, r, s) = (Vec3::new(0.2, 0.07, 0.15), 0.02, 2e5);
        let p = c.place(&x, r);
        let h = 1e-7;
        for k in 0..2 {
            let mut xp = x;
            xp[k] += h;
            let mut xm = x;
            xm[k] -= h;
            let grad = s * (c.volume(c.place(&xp, r).reach) - c.volume(c.place(&xm, r).reach)) / (2.0 * h);
            let f = c.load(s, &p, 0)[k];
            assert!((f + grad).abs() < 1e-6 * f.abs().max(1.0), "component {k}: {f} vs −{grad}");
        }
    }

    #[test]
    fn each_cell_takes_its_outermost_grain_and_the_lowest_id_of_equals() {
        let c = Cells::new(1, 4, [0.0, 0.0], 0.0, 1.0);
        let pos = [Vec3::new(0.5, 0.1, 0.5), Vec3::new(0.8, 0.1, 0.5), Vec3::new(0.8, 0.1, 0.5), Vec3::zeros()];
        let best = outermost(&c, &pos, &[0.1, 0.1, 0.1, 0.1], |i| i == 3);
        let cell = c.place(&pos[0], 0.1).cell;
        assert_eq!(best[cell].0, 1);
        assert_eq!(best.iter().filter(|b| b.0 != NONE).count(), 1);
    }

    #[test]
    fn an_empty_cell_goes_to_the_neighbour_whose_grain_reaches_farthest() {
        // 2 bands × 4 sectors; cell 1 (band 0, sector 1) empty; its sectors either side are
        // cells 0 and 2, the band above is cell 5.
        let c = Cells::new(2, 4, [0.0, 0.0], 0.0, 1.0);
        let mut best = vec![(7, 1.0); 8];
        best[1] = (NONE, 0.0);
        best[2] = (8, 1.5);
        best[5] = (9, 2.0);
        assert_eq!(c.beside(1).collect::<Vec<_>>(), [0, 2, 5]);
        let s = shares(&c, &best);
        assert_eq!(s, [0, 0, 0, 0, 0, 1, 0, 0]);
        // Equals: the first in order.
        best[5].1 = 1.5;
        assert_eq!(shares(&c, &best)[2], 1);
        // Wrapping around the axis: sector 0's before is sector 3.
        assert_eq!(c.beside(4).collect::<Vec<_>>(), [7, 5, 0]);
    }
}
