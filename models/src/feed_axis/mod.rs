//! The linear-motor feed axis (Rubio, Ibeas & Luo): the micro-milling cut that disturbs it
//! ([`micromilling`]).

pub mod micromilling;
