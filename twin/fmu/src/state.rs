//! An FMU state (fmi2GetFMUstate): the twin is bit-deterministic, so a state is what made it —
//! the parameters, the seed and the inputs of every control period since t = 0 — and setting it
//! replays them from the start (exact, at a cost linear in the time reached). Serialized as
//! little-endian bytes behind a magic word and the FMU's GUID.

use crate::parameters::Number;

/// The inputs of every control period since t = 0, as runs of periods with the same inputs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct History {
    /// Inputs per period.
    stride: usize,
    /// Periods of each run.
    counts: Vec<u64>,
    /// Each run's inputs, `stride` values per run.
    values: Vec<f64>,
}

impl History {
    pub fn new(stride: usize) -> Self {
        Self {
            stride,
            ..Self::default()
        }
    }

    /// One more period with `inputs` (bit for bit the last run's extends it).
    pub fn push(&mut self, inputs: &[f64]) {
        let start = self.values.len().saturating_sub(self.stride);
        let same = !self.counts.is_empty()
            && (self.values[start..].iter())
                .zip(inputs)
                .all(|(a, b)| a.to_bits() == b.to_bits());
        match self.counts.last_mut() {
            Some(count) if same => *count += 1,
            _ => {
                self.counts.push(1);
                self.values.extend_from_slice(inputs);
            }
        }
    }

    /// Whether each period holds `inputs` inputs.
    pub fn fits(&self, inputs: usize) -> bool {
        self.stride == inputs
    }

    pub fn clear(&mut self) {
        self.counts.clear();
        self.values.clear();
    }

    /// The runs: periods and inputs.
    pub fn runs(&self) -> impl Iterator<Item = (u64, &[f64])> {
        let stride = self.stride;
        (self.counts.iter().enumerate())
            .map(move |(k, &count)| (count, &self.values[k * stride..(k + 1) * stride]))
    }

    /// Periods in all.
    pub fn periods(&self) -> u64 {
        self.counts.iter().sum()
    }

    /// How many periods from the start `self` and `other` share.
    pub fn shared(&self, other: &History) -> u64 {
        let mut shared = 0;
        for ((a, x), (b, y)) in self.runs().zip(other.runs()) {
            let same = x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits());
            if !same {
                break;
            }
            shared += a.min(b);
            if a != b {
                break;
            }
        }
        shared
    }

    /// The periods after the first `skip`, as runs.
    pub fn after(&self, skip: u64) -> Vec<(u64, &[f64])> {
        let mut left = skip;
        let mut runs = Vec::new();
        for (count, inputs) in self.runs() {
            let dropped = left.min(count);
            left -= dropped;
            if count > dropped {
                runs.push((count - dropped, inputs));
            }
        }
        runs
    }
}

/// Everything that makes an instance's state.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// The FMU the state belongs to.
    pub guid: String,
    pub parameters: Vec<Number>,
    pub seed: i32,
    /// The inputs as set now.
    pub inputs: Vec<f64>,
    pub history: History,
}

const MAGIC: &[u8; 8] = b"twinfmu1";

impl State {
    /// The state as bytes (fmi2SerializeFMUstate).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = MAGIC.to_vec();
        let count = |out: &mut Vec<u8>, n: usize| out.extend((n as u64).to_le_bytes());
        count(&mut out, self.guid.len());
        out.extend(self.guid.as_bytes());
        out.extend(i64::from(self.seed).to_le_bytes());
        count(&mut out, self.parameters.len());
        for parameter in &self.parameters {
            let (tag, bits) = match *parameter {
                Number::Real(x) => (0u8, x.to_bits()),
                Number::Integer(i) => (1u8, i as u64),
            };
            out.push(tag);
            out.extend(bits.to_le_bytes());
        }
        count(&mut out, self.inputs.len());
        out.extend(self.inputs.iter().flat_map(|x| x.to_le_bytes()));
        count(&mut out, self.history.stride);
        count(&mut out, self.history.counts.len());
        for (periods, inputs) in self.history.runs() {
            out.extend(periods.to_le_bytes());
            out.extend(inputs.iter().flat_map(|x| x.to_le_bytes()));
        }
        out
    }

    /// A state from bytes (fmi2DeSerializeFMUstate); bytes not written by
    /// [`State::to_bytes`] are refused with what is wrong.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        let mut read = Reader { bytes, at: 0 };
        if read.take(MAGIC.len())? != MAGIC {
            return Err("serialized FMU state: not a twin FMU state (wrong magic bytes)".into());
        }
        let length = read.count()?;
        let guid = String::from_utf8(read.take(length)?.to_vec())
            .map_err(|_| "serialized FMU state: its GUID is not UTF-8".to_string())?;
        let seed = i32::try_from(read.u64()? as i64)
            .map_err(|_| "serialized FMU state: its seed does not fit an fmi2Integer")?;
        let mut parameters = Vec::new();
        for _ in 0..read.count()? {
            let tag = read.take(1)?[0];
            let bits = read.u64()?;
            parameters.push(match tag {
                0 => Number::Real(f64::from_bits(bits)),
                1 => Number::Integer(bits as i32),
                _ => {
                    return Err(format!(
                        "serialized FMU state: parameter kind {tag} unknown"
                    ))
                }
            });
        }
        let inputs = (0..read.count()?)
            .map(|_| read.f64())
            .collect::<Result<_, _>>()?;
        let mut history = History::new(read.count()?);
        for _ in 0..read.count()? {
            history.counts.push(read.u64()?);
            for _ in 0..history.stride {
                history.values.push(read.f64()?);
            }
        }
        if read.at != bytes.len() {
            return Err(format!(
                "serialized FMU state: {} bytes after its end",
                bytes.len() - read.at
            ));
        }
        Ok(Self {
            guid,
            parameters,
            seed,
            inputs,
            history,
        })
    }
}

/// Reads the serialized state, refusing a short one.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&end| end <= self.bytes.len());
        let end = end.ok_or_else(|| {
            format!(
                "serialized FMU state: cut short at byte {} of {}",
                self.at,
                self.bytes.len()
            )
        })?;
        let taken = &self.bytes[self.at..end];
        self.at = end;
        Ok(taken)
    }

    fn u64(&mut self) -> Result<u64, String> {
        let bytes = self.take(8)?;
        Ok(u64::from_le_bytes(bytes.try_into().unwrap_or_default()))
    }

    fn f64(&mut self) -> Result<f64, String> {
        self.u64().map(f64::from_bits)
    }

    /// A count, no larger than the bytes left could hold (a corrupt one is refused before any
    /// allocation).
    fn count(&mut self) -> Result<usize, String> {
        let n = self.u64()?;
        let left = (self.bytes.len() - self.at) as u64;
        usize::try_from(n)
            .ok()
            .filter(|_| n <= left)
            .ok_or_else(|| format!("serialized FMU state: a count of {n} with {left} bytes left"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn history(periods: &[(u64, f64)]) -> History {
        let mut history = History::new(1);
        for &(count, input) in periods {
            for _ in 0..count {
                history.push(&[input]);
            }
        }
        history
    }

    #[test]
    fn periods_of_the_same_inputs_make_one_run() {
        let h = history(&[(3, 1.0), (2, 0.0), (1, -0.0)]);
        assert_eq!(h.counts, [3, 2, 1], "-0 is not +0: another run");
        assert_eq!(h.periods(), 6);
        let runs: Vec<(u64, Vec<f64>)> = h
            .after(4)
            .into_iter()
            .map(|(n, v)| (n, v.to_vec()))
            .collect();
        assert_eq!(runs, [(1, vec![0.0]), (1, vec![-0.0])]);
    }

    #[test]
    fn shared_counts_the_common_start() {
        let a = history(&[(3, 1.0), (2, 0.0)]);
        assert_eq!(a.shared(&history(&[(3, 1.0)])), 3);
        assert_eq!(a.shared(&history(&[(2, 1.0)])), 2);
        assert_eq!(a.shared(&history(&[(3, 1.0), (5, 0.0)])), 5);
        assert_eq!(a.shared(&history(&[(3, 1.0), (1, 2.0)])), 3);
        assert_eq!(a.shared(&history(&[(1, 2.0)])), 0);
        assert_eq!(a.shared(&History::new(1)), 0);
    }

    #[test]
    fn a_state_survives_its_bytes_and_bad_bytes_are_refused() {
        let state = State {
            guid: "{abc}".into(),
            parameters: vec![Number::Real(f64::NAN), Number::Integer(-3)],
            seed: 7,
            inputs: vec![1.5, -0.0],
            history: {
                let mut h = History::new(2);
                h.push(&[1.0, 2.0]);
                h.push(&[1.0, 2.0]);
                h.push(&[0.0, 2.0]);
                h
            },
        };
        let bytes = state.to_bytes();
        let back = State::from_bytes(&bytes).unwrap();
        assert_eq!(back.to_bytes(), bytes, "bit for bit, NaN included");
        assert_eq!((back.seed, back.history.periods()), (7, 3));
        let short = State::from_bytes(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(short.contains("cut short"), "{short}");
        let mut long = bytes.clone();
        long.push(0);
        assert_eq!(
            State::from_bytes(&long).unwrap_err(),
            "serialized FMU state: 1 bytes after its end"
        );
        let mut wrong = bytes.clone();
        wrong[0] = b'x';
        assert!(State::from_bytes(&wrong).unwrap_err().contains("magic"));
        let mut huge = bytes;
        huge[8..16].copy_from_slice(&u64::MAX.to_le_bytes());
        assert!(State::from_bytes(&huge).unwrap_err().contains("a count of"));
    }
}
