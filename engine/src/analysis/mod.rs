//! Analysis of a model's state, between runs: what a script asks of a packing once it has
//! settled. Nothing here steps the model or changes it; every function reads the model as a
//! run left it (on a GPU, as the run's last download brought it back), so both backends give
//! the same answers from the same state.
//!
//! - [`contact_list`]: every contact and bond with its point, normal, overlap and forces, by
//!   the contact laws themselves ([`crate::physics::contact_law::contact`]), and each
//!   element's sums of them;
//! - [`fabric`]: the fabric tensor of the contact normals (Satake 1982, Oda 1982) and the
//!   coordination number of a region;
//! - [`measure`]: a region's mean stress (Love–Weber), porosity and coordination, and its
//!   strain from the best-fit displacement gradient between a reference state and now, in a
//!   [`Region`] (a sphere, a box or a vertical cylinder, [`crate::status::Region`]).

pub mod contact_list;
pub mod fabric;
pub mod measure;

pub use crate::status::Region;
pub use contact_list::{contact_list, Bond, ContactList, ContactRow, Other};
pub use fabric::{fabric, Fabric};
pub use measure::{measure, strain, Measurement, Strain};
