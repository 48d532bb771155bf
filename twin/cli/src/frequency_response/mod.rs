//! A measured frequency response, what `twin frf` makes and `twin analyze milling` reads: its
//! H1 estimate ([`estimate`]), its `frf.csv` file ([`file`](mod@file)) and one mode fitted to
//! it ([`fit`]).

pub mod estimate;
pub mod file;
pub mod fit;
