//! Stages 5 and 6: viscosity and external forces, each an optional slot that costs nothing
//! when unused (ε = 0 skips the viscosity pass; zero gravity skips the external pass), and
//! surface tension with adhesion (skipped when both settings are 0).

pub mod external;
pub(crate) mod surface_tension;
pub mod viscosity;
pub(crate) mod viscosity_implicit;
pub(crate) mod viscosity_stress;
pub(crate) mod wall_viscosity;
