//! The machining robot arm (Ilyukhin, Poduraev & Tatarintseva, DAAAM 2014): its program along the
//! part's contour ([`path`]) and the milling load the cast stock puts on its tool ([`milling`]).

pub mod milling;
pub mod path;
