//! A study as its TOML gives it, and the plan of its runs: which axis values and seed each run
//! takes.

use super::axis::{self, AxisText, GridAxis, RandomAxis};
use super::error::StudyError;
use framework::Registry;
use serde::{Deserialize, Serialize};
use twin::Noise;
use twin::{Scenario, ScenarioBuilder, ScenarioError};

/// Most runs one study may plan.
pub(super) const MAX_RUNS: usize = 100_000_000;
/// What fixes a study's runs: two folders with equal definitions hold parts of one study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyDefinition {
    /// The scenario as named on the command line (built-in name or file).
    pub scenario: String,
    /// The `--set` assignments applied to it before the axes.
    pub set: Vec<String>,
    pub grid: Vec<AxisText>,
    pub random: Vec<AxisText>,
    /// Runs per grid point.
    pub samples: usize,
    pub seed: u64,
    /// The scenario's TOML after `--set`: a changed scenario file is another study.
    pub base_toml: String,
}

/// A study ready to run: its definition and the parsed axes.
#[derive(Debug, Clone)]
pub struct Study {
    pub definition: StudyDefinition,
    grid: Vec<GridAxis>,
    random: Vec<RandomAxis>,
    base: ScenarioBuilder,
    runs: usize,
}

/// What one run is given: its seed and each axis's value, in axis order.
#[derive(Debug, Clone, PartialEq)]
pub struct RunPlan {
    pub index: usize,
    pub seed: u64,
    pub parameters: Vec<(String, toml::Value)>,
}

impl Study {
    /// Parses the axes and the base scenario; every error is one line naming the option.
    pub fn new(
        scenario: &str,
        set: &[String],
        grid: &[String],
        random: &[String],
        samples: usize,
        seed: u64,
        registry: &Registry,
    ) -> Result<Self, StudyError> {
        let base = set
            .iter()
            .try_fold(Scenario::open(scenario)?, |b, a| b.assign(a))?;
        let base_toml = base.clone().build(registry)?.toml;
        let parse = |texts: &[String], option: &str| -> Result<Vec<AxisText>, StudyError> {
            texts
                .iter()
                .map(|t| AxisText::parse(t, option).map_err(StudyError::Input))
                .collect()
        };
        let definition = StudyDefinition {
            scenario: scenario.into(),
            set: set.to_vec(),
            grid: parse(grid, "--grid")?,
            random: parse(random, "--random")?,
            samples,
            seed,
            base_toml,
        };
        Self::from_definition(definition, base)
    }

    fn from_definition(
        definition: StudyDefinition,
        base: ScenarioBuilder,
    ) -> Result<Self, StudyError> {
        let grid: Vec<GridAxis> = definition
            .grid
            .iter()
            .map(GridAxis::parse)
            .collect::<Result<_, _>>()
            .map_err(StudyError::Input)?;
        let random: Vec<RandomAxis> = definition
            .random
            .iter()
            .map(RandomAxis::parse)
            .collect::<Result<_, _>>()
            .map_err(StudyError::Input)?;
        let keys: Vec<&str> = grid
            .iter()
            .map(|a| a.key.as_str())
            .chain(random.iter().map(|a| a.key.as_str()))
            .collect();
        if let Some(twice) = keys
            .iter()
            .enumerate()
            .find(|(i, k)| keys[..*i].contains(k))
        {
            return Err(StudyError::Input(format!(
                "axis `{}` is given twice; one axis per key",
                twice.1
            )));
        }
        if definition.samples == 0 {
            return Err(StudyError::Input("--samples must be ≥ 1".into()));
        }
        let runs = grid
            .iter()
            .try_fold(definition.samples, |n, a| n.checked_mul(a.values.len()))
            .filter(|&n| n <= MAX_RUNS)
            .ok_or_else(|| {
                StudyError::Input(format!("the study plans more than {MAX_RUNS} runs"))
            })?;
        Ok(Self {
            definition,
            grid,
            random,
            base,
            runs,
        })
    }

    /// How many runs the study has.
    pub fn runs(&self) -> usize {
        self.runs
    }

    /// The axis keys, grid axes first: the parameter columns.
    pub fn keys(&self) -> Vec<String> {
        self.grid
            .iter()
            .map(|a| a.key.clone())
            .chain(self.random.iter().map(|a| a.key.clone()))
            .collect()
    }

    /// Run `index`'s seed and axis values.
    pub fn plan(&self, index: usize) -> Result<RunPlan, String> {
        let seed = axis::run_seed(self.definition.seed, index);
        let mut point = index / self.definition.samples;
        let mut parameters = vec![(String::new(), toml::Value::Boolean(false)); self.grid.len()];
        for (slot, axis) in parameters.iter_mut().zip(&self.grid).rev() {
            let n = axis.values.len();
            *slot = (axis.key.clone(), axis.values[point % n].clone());
            point /= n;
        }
        // The draws' own stream: the sensor noise uses `seed` itself.
        let mut rng = Noise::new(seed ^ 0xA5A5_5A5A_C3C3_3C3C);
        for axis in &self.random {
            parameters.push((axis.key.clone(), toml::Value::Float(axis.draw(&mut rng)?)));
        }
        Ok(RunPlan {
            index,
            seed,
            parameters,
        })
    }

    /// The scenario of a planned run: the base, its seed, then each axis value in order.
    pub fn scenario(&self, plan: &RunPlan) -> Result<ScenarioBuilder, ScenarioError> {
        let builder = self.base.clone().seed(plan.seed);
        plan.parameters
            .iter()
            .try_fold(builder, |builder, (key, value)| {
                match (key.as_str(), value) {
                    ("controller", toml::Value::String(name)) => Ok(builder.controller(name)),
                    _ => builder.set(key, value.clone()),
                }
            })
    }
}
