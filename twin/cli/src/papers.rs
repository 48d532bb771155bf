//! The seed papers the twin reproduces, as `twin list` shows them and `twin reproduce` takes
//! them: each paper's name, its one line, and whether `--engine` may choose its engine.

/// A paper `twin reproduce` knows.
pub struct Paper {
    pub name: &'static str,
    pub summary: &'static str,
    /// Whether `--engine` can choose its engine (not when an analysis builds its scenarios).
    pub any_engine: bool,
}

/// Every paper, in the order `twin list` shows them.
pub const PAPERS: &[Paper] = &[
    Paper {
        name: "whitworth",
        summary: "Perrusquía et al. 2022: task-space OSMC for constant-velocity cutting on a Whitworth shaper",
        any_engine: true,
    },
    Paper {
        name: "arm",
        summary: "Ilyukhin et al. 2014: machining robot, path speed corrected from motor currents",
        any_engine: true,
    },
    Paper {
        name: "lathe",
        summary: "Sudhakara & Landers 2003: parallel turning power loop, its equilibria and region of attraction",
        any_engine: false,
    },
    Paper {
        name: "feed-axis",
        summary: "Rubio, Ibeas & Luo: P-PI vs super-twisting SMC on a linear-motor feed axis under micro-milling (Table I)",
        any_engine: true,
    },
    Paper {
        name: "platform",
        summary: "Kalinski et al. 2013: two-wheeled platform, optimal control at the energy index vs two PIDs",
        any_engine: true,
    },
    Paper {
        name: "milling",
        summary: "Kaliński & Galewski 2013 §3: slender ball-end milling chatter reduced by spindle-speed programmes",
        any_engine: true,
    },
];
