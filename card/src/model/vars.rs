//! Storage of I, P and Q variables. P and Q values keep what a 48-bit PMAC float keeps
//! (35 magnitude bits, see [`super::float48::round48`]); I-variables are checked against
//! their table spec. Q-variables: one independent set per coordinate system ([DECISION]
//! pmac-commands §5.4).

use super::error::StateError;
use super::float48::round48;
use super::ivars::IVarTable;

/// I, P and Q values of one card.
#[derive(Debug, Clone)]
pub struct VarStore {
    table: IVarTable,
    i: Vec<f64>,
    p: Vec<f64>,
    q: Vec<Vec<f64>>,
    /// Keep P/Q values as IEEE doubles (no rounding to the 48-bit PMAC float).
    ieee: bool,
}

impl VarStore {
    /// Factory state: I-variables at their defaults, P and Q zero. `vars` variables per
    /// family, `coords` Q sets.
    pub fn new(table: IVarTable, coords: u16) -> Self {
        let n = table.len();
        let i = table.defaults();
        VarStore {
            table,
            i,
            p: vec![0.0; n],
            q: vec![vec![0.0; n]; coords as usize],
            ieee: false,
        }
    }

    /// Factory state with the profile's own P and Q counts and arithmetic.
    pub(crate) fn for_limits(table: IVarTable, lim: &crate::domain::Limits) -> Self {
        let mut s = VarStore::new(table, lim.coords);
        s.p = vec![0.0; lim.p_vars as usize];
        s.q = vec![vec![0.0; lim.q_vars as usize]; usize::from(lim.coords)];
        s.ieee = lim.sem.ieee;
        s
    }

    /// The I-variable table (specs).
    pub fn table(&self) -> &IVarTable {
        &self.table
    }

    /// Number of variables per family.
    pub fn count(&self) -> usize {
        self.i.len()
    }

    /// Value of I`n` as stored (no mirror side effects; see `CardState::read_ivar`).
    pub fn i(&self, n: u32) -> Result<f64, StateError> {
        self.i
            .get(n as usize)
            .copied()
            .ok_or(StateError::NoSuchVariable(n))
    }

    /// Assign I`n` after range/read-only checks; returns the value stored.
    pub fn set_i(&mut self, n: u32, v: f64) -> Result<f64, StateError> {
        let spec = self.table.get(n).ok_or(StateError::NoSuchVariable(n))?;
        if spec.read_only {
            return Err(StateError::ReadOnly(format!("I{n}")));
        }
        let v = spec
            .accept(v)
            .ok_or_else(|| StateError::ValueOutOfRange(format!("I{n}")))?;
        let v = if spec.kind == super::ivars::IKind::Float {
            round48(v)
        } else {
            v
        };
        self.i[n as usize] = v;
        Ok(v)
    }

    /// Store I`n` without checks (reset-time adjustments, loading a saved image).
    pub fn force_i(&mut self, n: u32, v: f64) {
        if let Some(slot) = self.i.get_mut(n as usize) {
            *slot = v;
        }
    }

    /// Restore I`n` to its factory default (`In=*`).
    pub fn default_i(&mut self, n: u32) -> Result<f64, StateError> {
        let d = self
            .table
            .get(n)
            .ok_or(StateError::NoSuchVariable(n))?
            .default;
        self.i[n as usize] = d;
        Ok(d)
    }

    /// Every I-variable to its factory default.
    pub fn reset_i(&mut self) {
        self.i = self.table.defaults();
    }

    /// Value of P`n`.
    pub fn p(&self, n: u32) -> Result<f64, StateError> {
        self.p
            .get(n as usize)
            .copied()
            .ok_or(StateError::NoSuchVariable(n))
    }

    /// Assign P`n` (rounded to 48-bit float precision); returns the value stored.
    pub fn set_p(&mut self, n: u32, v: f64) -> Result<f64, StateError> {
        let slot = self
            .p
            .get_mut(n as usize)
            .ok_or(StateError::NoSuchVariable(n))?;
        *slot = if self.ieee { v } else { round48(v) };
        Ok(*slot)
    }

    /// Value of Q`n` of coordinate system `cs` (1-based).
    pub fn q(&self, cs: u16, n: u32) -> Result<f64, StateError> {
        let set = self.q_set(cs)?;
        set.get(n as usize)
            .copied()
            .ok_or(StateError::NoSuchVariable(n))
    }

    /// Assign Q`n` of coordinate system `cs` (1-based); returns the value stored.
    pub fn set_q(&mut self, cs: u16, n: u32, v: f64) -> Result<f64, StateError> {
        let set = cs
            .checked_sub(1)
            .and_then(|k| self.q.get_mut(k as usize))
            .ok_or(StateError::NoSuchUnit(cs as u32))?;
        let slot = set
            .get_mut(n as usize)
            .ok_or(StateError::NoSuchVariable(n))?;
        *slot = if self.ieee { v } else { round48(v) };
        Ok(*slot)
    }

    fn q_set(&self, cs: u16) -> Result<&Vec<f64>, StateError> {
        cs.checked_sub(1)
            .and_then(|k| self.q.get(k as usize))
            .ok_or(StateError::NoSuchUnit(cs as u32))
    }

    /// All I values (persistence).
    pub fn i_all(&self) -> &[f64] {
        &self.i
    }
    /// All P values (persistence).
    pub fn p_all(&self) -> &[f64] {
        &self.p
    }
    /// All Q sets (persistence).
    pub fn q_all(&self) -> &[Vec<f64>] {
        &self.q
    }

    /// Load saved values: each vector is copied as far as both lengths allow (a saved image of
    /// another size only fills the common part).
    pub fn load(&mut self, i: &[f64], p: &[f64], q: &[Vec<f64>]) {
        for (dst, src) in self.i.iter_mut().zip(i) {
            *dst = *src;
        }
        for (dst, src) in self.p.iter_mut().zip(p) {
            *dst = round48(*src);
        }
        for (set, saved) in self.q.iter_mut().zip(q) {
            for (dst, src) in set.iter_mut().zip(saved) {
                *dst = round48(*src);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Profile;

    fn store() -> VarStore {
        VarStore::new(IVarTable::new(Profile::Pmac2), 8)
    }

    #[test]
    fn i_defaults_ranges_and_star() {
        let mut s = store();
        assert_eq!(s.i(3), Ok(1.0));
        assert_eq!(s.set_i(3, 2.0), Ok(2.0));
        assert_eq!(
            s.set_i(3, 7.0),
            Err(StateError::ValueOutOfRange("I3".into()))
        );
        assert_eq!(s.i(3), Ok(2.0));
        assert_eq!(s.set_i(130, 1234.6), Ok(1235.0));
        assert_eq!(s.default_i(3), Ok(1.0));
        assert_eq!(s.i(1024), Err(StateError::NoSuchVariable(1024)));
        assert_eq!(s.set_i(1024, 0.0), Err(StateError::NoSuchVariable(1024)));
        assert_eq!(s.set_i(115, 0.1), Ok(round48(0.1)));
    }

    #[test]
    fn p_and_q_per_cs() {
        let mut s = store();
        assert_eq!(s.p(0), Ok(0.0));
        assert_eq!(s.set_p(1, 25.0), Ok(25.0));
        assert_eq!(s.set_q(1, 10, 35.0), Ok(35.0));
        assert_eq!(s.q(2, 10), Ok(0.0));
        assert_eq!(s.q(1, 10), Ok(35.0));
        assert_eq!(s.q(9, 10), Err(StateError::NoSuchUnit(9)));
        assert_eq!(s.set_q(0, 1, 1.0), Err(StateError::NoSuchUnit(0)));
        assert_eq!(s.p(1024), Err(StateError::NoSuchVariable(1024)));
        let v = 1.0 + 2f64.powi(-40);
        assert_eq!(s.set_p(2, v), Ok(1.0));
    }

    #[test]
    fn turbo_has_8192() {
        let mut s = VarStore::new(IVarTable::new(Profile::Turbo), 16);
        assert_eq!(s.set_p(8191, 3.0), Ok(3.0));
        assert_eq!(s.set_q(16, 8191, 3.0), Ok(3.0));
        assert_eq!(s.i(68), Ok(15.0));
        assert!(matches!(s.set_i(20, 1.0), Err(StateError::ReadOnly(_))));
    }
}
