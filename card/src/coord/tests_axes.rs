//! Tests of axis definitions, the axis→motor matrix, PMATCH and transformation matrices.

use super::axes::{AxisTable, AxisVec, MotorAxisDef};
use super::transform::TransformBank;
use super::CoordError;
use crate::domain::ast::{Axis, AxisDef, AxisTerm};
use crate::domain::ErrCode;

fn ast(terms: &[(f64, Axis)], offset: f64) -> AxisDef {
    AxisDef {
        terms: terms
            .iter()
            .map(|&(scale, axis)| AxisTerm { scale, axis })
            .collect(),
        offset,
    }
}

fn def(terms: &[(f64, Axis)], offset: f64) -> MotorAxisDef {
    MotorAxisDef::from_ast(&ast(terms, offset)).unwrap()
}

fn axes(v: &[(usize, f64)]) -> AxisVec {
    let mut a = AxisVec::zeros();
    for &(k, x) in v {
        a[k] = x;
    }
    a
}

#[test]
fn membership_rules_and_err003() {
    let mut t = AxisTable::new(8, 8);
    t.define(1, 4, def(&[(5000.0, Axis::A)], 0.0)).unwrap();
    // The same motor in another C.S. is refused with ERR003.
    let e = t.define(2, 4, def(&[(5000.0, Axis::A)], 0.0)).unwrap_err();
    assert_eq!(e, CoordError::MotorInOtherCs(4, 1));
    assert_eq!(e.err_code(), Some(ErrCode::Data));
    // `#4->` in &2 answers 0 (None), in &1 the definition.
    assert!(t.query(2, 4).is_none());
    assert_eq!(t.query(1, 4), Some(&def(&[(5000.0, Axis::A)], 0.0)));
    // `#4->0` in &2 has no effect; in &1 it frees the motor for &2.
    t.undefine_motor(2, 4).unwrap();
    assert_eq!(t.cs_of(4), Some(1));
    t.undefine_motor(1, 4).unwrap();
    t.define(2, 4, def(&[(5000.0, Axis::A)], 0.0)).unwrap();
    assert_eq!(t.cs_of(4), Some(2));
    // Redefinition inside the same C.S. overwrites.
    t.define(2, 4, def(&[(10.0, Axis::B)], 3.0)).unwrap();
    assert_eq!(t.query(2, 4), Some(&def(&[(10.0, Axis::B)], 3.0)));
    // UNDEFINE clears one C.S., UNDEFINE ALL every one.
    t.define(1, 1, def(&[(1.0, Axis::X)], 0.0)).unwrap();
    t.undefine(2);
    assert_eq!((t.cs_of(4), t.cs_of(1)), (None, Some(1)));
    t.undefine_all();
    assert_eq!(t.cs_of(1), None);
    // Unit numbers outside the card.
    assert_eq!(
        t.define(9, 1, def(&[(1.0, Axis::X)], 0.0)),
        Err(CoordError::NoSuchUnit(9))
    );
    assert_eq!(
        t.define(1, 0, def(&[(1.0, Axis::X)], 0.0)),
        Err(CoordError::NoSuchUnit(0))
    );
    assert!(t.cs_axes(1).is_empty());
}

#[test]
fn malformed_definitions_are_err003() {
    let bad = [
        ast(&[(1.0, Axis::X), (1.0, Axis::U)], 0.0),
        ast(&[(1.0, Axis::A), (1.0, Axis::B)], 0.0),
        ast(
            &[
                (1.0, Axis::X),
                (1.0, Axis::Y),
                (1.0, Axis::Z),
                (1.0, Axis::X),
            ],
            0.0,
        ),
        ast(&[(1.0, Axis::X), (2.0, Axis::X)], 0.0),
        ast(&[(f64::NAN, Axis::X)], 0.0),
        ast(&[(1.0, Axis::X)], f64::INFINITY),
        ast(&[(1.0, Axis::I)], 0.0),
    ];
    // A definition without terms is `#m->I` (inverse kinematics), not a defect.
    assert_eq!(
        MotorAxisDef::from_ast(&ast(&[], 0.0)),
        Ok(MotorAxisDef::Inverse)
    );
    for d in &bad {
        let e = MotorAxisDef::from_ast(d).unwrap_err();
        assert_eq!(e.err_code(), Some(ErrCode::Data), "{d:?}");
    }
}

#[test]
fn linear_combination_matrix_maps_axes_to_motors() {
    // Seed example: 30° rotation of X/Y with 10000 counts/unit, Z with an offset.
    let mut t = AxisTable::new(8, 8);
    t.define(1, 1, def(&[(8660.0, Axis::X), (-5000.0, Axis::Y)], 0.0))
        .unwrap();
    t.define(1, 2, def(&[(5000.0, Axis::X), (8660.0, Axis::Y)], 0.0))
        .unwrap();
    t.define(1, 3, def(&[(2000.0, Axis::Z)], -6000.0)).unwrap();
    let m = t.cs_axes(1);
    assert_eq!(m.motors, [1, 2, 3]);
    let p = m.motor_positions(&axes(&[(0, 1.0), (1, 2.0), (2, 3.0)]), &[]);
    assert_eq!(
        p.as_slice(),
        &[8660.0 - 10000.0, 5000.0 + 17320.0, 6000.0 - 6000.0]
    );
    // PMATCH inverts it exactly (square regular system).
    let back = m.pmatch(p.as_slice(), &AxisVec::zeros());
    for (k, want) in [(0, 1.0), (1, 2.0), (2, 3.0)] {
        assert!((back[k] - want).abs() < 1e-9, "axis {k}: {}", back[k]);
    }
}

#[test]
fn pmatch_gantry_uses_lowest_motor_and_keeps_phantoms() {
    let mut t = AxisTable::new(8, 8);
    t.define(1, 2, def(&[(100.0, Axis::X)], 0.0)).unwrap();
    t.define(1, 5, def(&[(200.0, Axis::X)], 50.0)).unwrap();
    let m = t.cs_axes(1);
    let prev = axes(&[(1, 7.0), (3, -2.0)]);
    // Motor 2 at 300 → X = 3 although motor 5 disagrees.
    let a = m.pmatch(&[300.0, 9999.0], &prev);
    assert!((a[0] - 3.0).abs() < 1e-12);
    assert_eq!((a[1], a[3]), (7.0, -2.0), "phantom axes keep their value");
    // Under-determined (one motor on X+Y): minimum change from the previous position.
    let mut t = AxisTable::new(8, 8);
    t.define(1, 1, def(&[(1.0, Axis::X), (1.0, Axis::Y)], 0.0))
        .unwrap();
    let m = t.cs_axes(1);
    let a = m.pmatch(&[4.0], &axes(&[(0, 1.0), (1, 1.0)]));
    assert!(
        (a[0] - 2.0).abs() < 1e-12 && (a[1] - 2.0).abs() < 1e-12,
        "{a:?}"
    );
    // Non-finite motor positions are ignored rather than propagated.
    let a = m.pmatch(&[f64::NAN], &axes(&[(0, 1.0)]));
    assert_eq!(a[0], 1.0);
}

#[test]
fn inverse_kinematics_motor_is_a_member_that_holds() {
    let mut t = AxisTable::new(8, 8);
    t.define(3, 1, MotorAxisDef::Inverse).unwrap();
    t.define(3, 2, def(&[(10.0, Axis::X)], 0.0)).unwrap();
    assert_eq!(
        t.define(1, 1, def(&[(1.0, Axis::X)], 0.0))
            .unwrap_err()
            .err_code(),
        Some(ErrCode::Data)
    );
    let m = t.cs_axes(3);
    let p = m.motor_positions(&axes(&[(0, 2.0)]), &[123.0, 0.0]);
    assert_eq!(p.as_slice(), &[123.0, 20.0]);
}

#[test]
fn transformation_matrices() {
    let mut b = TransformBank::default();
    assert_eq!(b.tsel(1), Err(CoordError::NoMatrix(1)));
    assert_eq!(b.adis([1.0, 2.0, 3.0]), Err(CoordError::NoMatrix(0)));
    b.define(2);
    b.tsel(2).unwrap();
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let rot = [c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0];
    b.arot(rot).unwrap();
    b.adis([7.5, 12.5, 25.0]).unwrap();
    // programmed = R·base + D, row-major R.
    let base = axes(&[(0, 1.0), (1, 0.0), (2, 0.0), (3, 9.0)]);
    let prog = b.current().to_prog(&base);
    assert!((prog[0] - (c + 7.5)).abs() < 1e-12 && (prog[1] - (-s + 12.5)).abs() < 1e-12);
    assert_eq!((prog[2], prog[3]), (25.0, 9.0));
    let back = b.current().to_base(&prog);
    assert!((back - base).norm() < 1e-12);
    // IROT twice more = 90° total; IDIS adds.
    b.irot(rot).unwrap();
    b.irot(rot).unwrap();
    b.idis([0.5, -0.5, 0.0]).unwrap();
    let prog = b.current().to_prog(&base);
    assert!(
        (prog[0] - 8.0).abs() < 1e-12 && (prog[1] - (-1.0 + 12.0)).abs() < 1e-12,
        "{prog:?}"
    );
    // Singular and non-finite matrices are refused and leave the matrix unchanged.
    let before = b.current();
    assert_eq!(
        b.arot([1.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0]),
        Err(CoordError::SingularMatrix)
    );
    assert!(b.arot([f64::NAN; 9]).is_err());
    assert!(b.adis([f64::INFINITY, 0.0, 0.0]).is_err());
    assert_eq!(b.current(), before);
    b.tinit().unwrap();
    assert_eq!(b.current().to_prog(&base), base);
    b.tsel(0).unwrap();
    assert_eq!(b.selected(), 0);
}
