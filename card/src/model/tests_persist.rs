use super::*;
use crate::domain::Profile;
use crate::model::{CardState, Space};

fn sample() -> PersistImage {
    let mut s = CardState::new(Profile::Pmac2);
    s.set_ivar(130, 5000.0).unwrap();
    s.vars.set_p(7, 2.5).unwrap();
    s.password = "Secret".into();
    s.to_image(b"PROG1 X10".to_vec())
}

#[test]
fn truncated_and_corrupt_files_are_rejected() {
    let bytes = encode(&sample());
    for cut in [0, 5, 8, 19, 20, bytes.len() / 2, bytes.len() - 1] {
        let r = decode(&bytes[..cut]);
        assert!(
            matches!(
                r,
                Err(PersistError::BadMagic) | Err(PersistError::Truncated { .. })
            ),
            "cut {cut}: {r:?}"
        );
    }
    let mut flipped = bytes.clone();
    flipped[30] ^= 0x40;
    assert!(matches!(decode(&flipped), Err(PersistError::Checksum)));
    let mut foreign = bytes.clone();
    foreign[0] = b'X';
    assert!(matches!(decode(&foreign), Err(PersistError::BadMagic)));
    let mut newer = bytes.clone();
    newer[8] = 9;
    assert!(matches!(decode(&newer), Err(PersistError::Version(9))));
    let mut huge = bytes.clone();
    huge[12..20].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(matches!(decode(&huge), Err(PersistError::BadLength)));
    let mut extra = bytes.clone();
    extra.push(0);
    assert!(matches!(decode(&extra), Err(PersistError::BadLength)));
    // Valid frame around a payload that is not an image.
    let payload = [1u8, 2, 3];
    let mut junk = Vec::new();
    junk.extend_from_slice(MAGIC);
    junk.extend_from_slice(&VERSION.to_le_bytes());
    junk.extend_from_slice(&3u64.to_le_bytes());
    junk.extend_from_slice(&payload);
    junk.extend_from_slice(&fnv1a64(&payload).to_le_bytes());
    assert!(matches!(decode(&junk), Err(PersistError::Decode(_))));
}

#[test]
fn image_keeps_memory_regions() {
    let mut s = CardState::new(Profile::Pmac2);
    s.write(Space::Y, 0x0730, 0x123456);
    let img = s.to_image(Vec::new());
    let mut t = CardState::new(Profile::Pmac2);
    t.reset(Some(&img)).unwrap();
    assert_eq!(t.read(Space::Y, 0x0730), 0x123456);
}

#[test]
fn saved_values_come_back_bit_exact() {
    // Found by fuzzing: JSON numbers must parse back to the same f64 (serde_json's
    // float_roundtrip), or SAVE + $$$ moves a value by one unit in the last place.
    let values = vec![
        -14700.061580553913,
        0.1,
        1.0 / 3.0,
        2.0e-300,
        -9.87654321e17,
    ];
    let mut img = sample();
    img.qvars = vec![values.clone()];
    img.pvars = values.clone();
    img.ivars = values.clone();
    let back = decode(&encode(&img)).unwrap();
    for got in [&back.qvars[0], &back.pvars, &back.ivars] {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(got), bits(&values));
    }
    assert_eq!(encode(&back), encode(&img));
}
