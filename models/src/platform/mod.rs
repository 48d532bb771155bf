//! The two-wheeled mobile platform (Kaliński et al. 2013, §2): the paths of its point H
//! ([`path`]) and the tyre–floor contact of its wheels ([`tyre`]).

pub mod path;
pub mod tyre;
