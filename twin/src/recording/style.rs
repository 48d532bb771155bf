//! How a recording draws: the links' palette, the bodies' and the crashes' colours, and how
//! finely a circle is drawn.

/// The crashes' colour (red: nothing else in the view is).
pub(super) const COLLISION_COLOR: [u8; 3] = [255, 40, 40];
/// The bodies' colour when their shapes have none (neutral beside the links' palette).
pub(super) const BODY_COLOR: [u8; 3] = [158, 163, 178];
/// Segments of the polygon drawing a circle.
pub(super) const CIRCLE_SEGMENTS: usize = 48;
/// Colours of the links, one each in turn (distinct on the viewer's dark background).
pub(super) const LINK_PALETTE: [[u8; 3]; 8] = [
    [86, 180, 233],
    [230, 159, 0],
    [0, 158, 115],
    [204, 121, 167],
    [240, 228, 66],
    [213, 94, 0],
    [148, 103, 189],
    [0, 114, 178],
];
