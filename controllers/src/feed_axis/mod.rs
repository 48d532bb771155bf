//! Linear-motor feed-axis controllers (Rubio, Ibeas & Luo): P-PI and super-twisting.

pub mod p_pi;
pub mod stsmc;
pub mod stsmc_dob;
