//! A study's axes: grid axes (`key=lin(a,b,n)`, `log(a,b,n)`, a list) span a Cartesian product;
//! random axes (`key=normal(m,σ)`, `uniform(a,b)`, `lognormal(μ,σ)`, each optionally truncated
//! to `[lo, hi]` by two more arguments) are drawn per run from a generator seeded by (study seed,
//! run index), so a run is reproducible alone.

use serde::{Deserialize, Serialize};
use twin::Noise;

/// Most points one grid axis may have.
const MAX_AXIS_POINTS: usize = 100_000;
/// Draws tried for one truncated value before the window is called too narrow.
const MAX_TRUNCATED_DRAWS: usize = 100_000;

/// One axis as written (`key=spec`), kept as text: the study's identity and its CSV columns.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AxisText {
    pub key: String,
    pub spec: String,
}

impl AxisText {
    /// Splits `key=spec` at the first `=`.
    pub fn parse(text: &str, option: &str) -> Result<Self, String> {
        let (key, spec) = text
            .split_once('=')
            .ok_or_else(|| format!("{option} {text}: expected key=values"))?;
        let (key, spec) = (key.trim(), spec.trim());
        if key.is_empty() || spec.is_empty() {
            return Err(format!("{option} {text}: expected key=values"));
        }
        Ok(Self {
            key: key.into(),
            spec: spec.into(),
        })
    }
}

/// A grid axis: its key and its values in order.
#[derive(Debug, Clone, PartialEq)]
pub struct GridAxis {
    pub key: String,
    pub values: Vec<toml::Value>,
}

impl GridAxis {
    /// `lin(a,b,n)` and `log(a,b,n)` (n points, ends included), a TOML array `[a, b, …]`, or
    /// a comma-separated list of TOML values (bare words are strings).
    pub fn parse(axis: &AxisText) -> Result<Self, String> {
        let error = |reason: String| format!("--grid {}={}: {reason}", axis.key, axis.spec);
        let values = match call(&axis.spec) {
            Some((name @ ("lin" | "log"), args)) => spaced(name, &args).map_err(error)?,
            Some((name, _)) => {
                return Err(error(format!(
                    "unknown grid `{name}(…)`; use lin(a,b,n), log(a,b,n) or a list"
                )))
            }
            None => list(&axis.spec).map_err(error)?,
        };
        if values.is_empty() {
            return Err(error("the grid is empty".into()));
        }
        Ok(Self {
            key: axis.key.clone(),
            values,
        })
    }
}

/// n evenly spaced points, linearly or logarithmically.
fn spaced(name: &str, args: &[f64]) -> Result<Vec<toml::Value>, String> {
    let [a, b, n] = args else {
        return Err(format!("{name}(a, b, n) takes three numbers"));
    };
    if n.fract() != 0.0 || *n < 1.0 || *n > MAX_AXIS_POINTS as f64 {
        return Err(format!(
            "n must be a whole number from 1 to {MAX_AXIS_POINTS}, got {n}"
        ));
    }
    if name == "log" && !(*a > 0.0 && *b > 0.0) {
        return Err("log(a, b, n) needs a > 0 and b > 0".into());
    }
    let n = *n as usize;
    let at = |i: usize| {
        let t = if n == 1 {
            0.0
        } else {
            i as f64 / (n - 1) as f64
        };
        match name {
            "log" => (a.ln() + t * (b.ln() - a.ln())).exp(),
            _ => a + t * (b - a),
        }
    };
    // The ends exactly as given, not as the formula rounds them.
    Ok((0..n)
        .map(|i| match i {
            0 => *a,
            i if i == n - 1 => *b,
            i => at(i),
        })
        .map(toml::Value::Float)
        .collect())
}

/// `[a, b]` as TOML, else `a, b, c` with each item TOML or a bare string.
fn list(spec: &str) -> Result<Vec<toml::Value>, String> {
    let text = if spec.starts_with('[') {
        spec.to_string()
    } else {
        let items: Vec<String> = spec
            .split(',')
            .map(|item| {
                let item = item.trim();
                match format!("v = {item}").parse::<toml::Table>() {
                    Ok(_) => item.to_string(),
                    Err(_) => toml::Value::String(item.into()).to_string(),
                }
            })
            .collect();
        format!("[{}]", items.join(", "))
    };
    let mut table = format!("v = {text}")
        .parse::<toml::Table>()
        .map_err(|_| format!("`{spec}` is not a list of values"))?;
    match table.remove("v") {
        Some(toml::Value::Array(values)) => Ok(values),
        _ => Err(format!("`{spec}` is not a list of values")),
    }
}

/// `name(a, b, …)` with numeric arguments; `None` when the text is not a call.
fn call(spec: &str) -> Option<(&str, Vec<f64>)> {
    let (name, rest) = spec.split_once('(')?;
    let name = name.trim();
    if !name.chars().all(|c| c.is_ascii_alphabetic()) || name.is_empty() {
        return None;
    }
    let inner = rest.trim_end().strip_suffix(')')?;
    let args = inner
        .split(',')
        .map(|a| a.trim().parse::<f64>().unwrap_or(f64::NAN))
        .collect();
    Some((name, args))
}

/// A distribution a random axis draws from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Distribution {
    Normal {
        mean: f64,
        sd: f64,
    },
    Uniform {
        low: f64,
        high: f64,
    },
    /// exp of a normal(μ, σ): μ and σ of the logarithm.
    LogNormal {
        mu: f64,
        sigma: f64,
    },
}

/// A random axis: its key, distribution and optional truncation window.
#[derive(Debug, Clone, PartialEq)]
pub struct RandomAxis {
    pub key: String,
    pub distribution: Distribution,
    pub window: Option<[f64; 2]>,
}

impl RandomAxis {
    pub fn parse(axis: &AxisText) -> Result<Self, String> {
        let error = |reason: String| format!("--random {}={}: {reason}", axis.key, axis.spec);
        let (name, args) = call(&axis.spec).ok_or_else(|| {
            error("expected normal(m,sd), uniform(a,b) or lognormal(mu,sigma)".into())
        })?;
        if args.iter().any(|a| !a.is_finite()) {
            return Err(error("the arguments must be finite numbers".into()));
        }
        let (distribution, window) = match (name, args.as_slice()) {
            ("normal", [mean, sd, rest @ ..]) if *sd > 0.0 => (
                Distribution::Normal {
                    mean: *mean,
                    sd: *sd,
                },
                rest,
            ),
            ("lognormal", [mu, sigma, rest @ ..]) if *sigma > 0.0 => (
                Distribution::LogNormal {
                    mu: *mu,
                    sigma: *sigma,
                },
                rest,
            ),
            ("uniform", [low, high]) if low < high => (
                Distribution::Uniform {
                    low: *low,
                    high: *high,
                },
                &[][..],
            ),
            ("normal" | "lognormal" | "uniform", _) => {
                return Err(error(format!(
                    "{name} takes {}",
                    match name {
                        "uniform" => "(a, b) with a < b",
                        "normal" => "(mean, sd[, lo, hi]) with sd > 0",
                        _ => "(mu, sigma[, lo, hi]) with sigma > 0",
                    }
                )))
            }
            _ => return Err(error(format!("unknown distribution `{name}`"))),
        };
        let window = match window {
            [] => None,
            [lo, hi] if lo < hi => Some([*lo, *hi]),
            _ => return Err(error("the truncation window needs lo < hi".into())),
        };
        Ok(Self {
            key: axis.key.clone(),
            distribution,
            window,
        })
    }

    /// One draw; a truncated axis redraws until the value is inside its window.
    pub fn draw(&self, rng: &mut Noise) -> Result<f64, String> {
        for _ in 0..MAX_TRUNCATED_DRAWS {
            let value = match self.distribution {
                Distribution::Normal { mean, sd } => mean + sd * rng.gaussian(),
                Distribution::LogNormal { mu, sigma } => (mu + sigma * rng.gaussian()).exp(),
                Distribution::Uniform { low, high } => low + (high - low) * rng.uniform(),
            };
            match self.window {
                Some([lo, hi]) if !(lo..=hi).contains(&value) => continue,
                _ => return Ok(value),
            }
        }
        Err(format!(
            "--random {}: no draw in {MAX_TRUNCATED_DRAWS} fell inside the window; widen it",
            self.key
        ))
    }
}

/// A run's seed from the study's seed and the run's index: the run's sensor noise and its
/// random-axis draws come from it alone. Kept below 2⁶³ (a TOML integer).
pub fn run_seed(study_seed: u64, index: usize) -> u64 {
    let mut rng = Noise::new(study_seed ^ (index as u64).wrapping_mul(0xD1B5_4A32_D192_ED03));
    rng.next_u64() >> 1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(spec: &str) -> Result<Vec<toml::Value>, String> {
        GridAxis::parse(&AxisText::parse(&format!("k={spec}"), "--grid")?).map(|a| a.values)
    }

    #[test]
    fn grids_span_their_ends() {
        let floats =
            |v: Vec<toml::Value>| v.iter().map(|x| x.as_float().unwrap()).collect::<Vec<_>>();
        assert_eq!(
            floats(grid("lin(0.01,0.05,5)").unwrap()),
            [0.01, 0.02, 0.03, 0.04, 0.05]
        );
        let log = floats(grid("log(1,100,3)").unwrap());
        assert_eq!(log[0], 1.0);
        assert!((log[1] - 10.0).abs() < 1e-12);
        assert_eq!(log[2], 100.0);
        assert_eq!(grid("osmc, smc2").unwrap()[1].as_str(), Some("smc2"));
        assert_eq!(grid("[1, 2.5]").unwrap()[1].as_float(), Some(2.5));
        assert_eq!(grid("3").unwrap()[0].as_integer(), Some(3));
    }

    #[test]
    fn bad_axes_are_refused_with_the_reason() {
        assert!(grid("lin(0,1)").unwrap_err().contains("three numbers"));
        assert!(grid("lin(0,1,0)").unwrap_err().contains("whole number"));
        assert!(grid("log(0,1,3)").unwrap_err().contains("a > 0"));
        assert!(grid("[]").unwrap_err().contains("empty"));
        assert!(grid("cubic(1,2,3)").unwrap_err().contains("unknown grid"));
        let random = |spec: &str| RandomAxis::parse(&AxisText::parse(spec, "--random").unwrap());
        assert!(random("m=normal(5,-1)").unwrap_err().contains("sd > 0"));
        assert!(random("m=uniform(2,1)").unwrap_err().contains("a < b"));
        assert!(random("m=gamma(2,1)")
            .unwrap_err()
            .contains("unknown distribution"));
        assert!(random("m=normal(5,1,6,4)").unwrap_err().contains("lo < hi"));
        assert!(random("m=normal(x,1)").unwrap_err().contains("finite"));
        assert!(AxisText::parse("novalue", "--grid").is_err());
    }

    #[test]
    fn draws_follow_their_distribution_and_window() {
        let axis =
            RandomAxis::parse(&AxisText::parse("m=normal(5,0.25)", "--random").unwrap()).unwrap();
        let mut rng = Noise::new(7);
        let draws: Vec<f64> = (0..20_000).map(|_| axis.draw(&mut rng).unwrap()).collect();
        let mean = draws.iter().sum::<f64>() / draws.len() as f64;
        let var = draws.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / draws.len() as f64;
        assert!((mean - 5.0).abs() < 0.01, "{mean}");
        assert!((var.sqrt() - 0.25).abs() < 0.01, "{}", var.sqrt());
        let truncated =
            RandomAxis::parse(&AxisText::parse("m=normal(5,1,4.5,5.2)", "--random").unwrap())
                .unwrap();
        assert!((0..1000).all(|_| (4.5..=5.2).contains(&truncated.draw(&mut rng).unwrap())));
        let narrow =
            RandomAxis::parse(&AxisText::parse("m=normal(0,1,50,51)", "--random").unwrap())
                .unwrap();
        assert!(narrow.draw(&mut rng).unwrap_err().contains("widen"));
        assert_ne!(run_seed(1, 0), run_seed(1, 1));
        assert_eq!(run_seed(1, 5), run_seed(1, 5));
        assert!(run_seed(u64::MAX, usize::MAX) < 1 << 63);
    }
}
