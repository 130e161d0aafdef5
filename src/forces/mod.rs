//! Stages 5 and 6: viscosity and external forces, each an optional slot that costs nothing
//! when unused (ε = 0 skips the viscosity pass; zero gravity skips the external pass).

pub mod external;
pub mod viscosity;
pub(crate) mod wall_viscosity;
