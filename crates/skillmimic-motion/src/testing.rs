//! Synthetic inputs for tests and the fuzzer's seed corpus (not real motion).

use crate::layout::PT_WIDTH;

/// `t` plausible rows of the BallPlay-M 337-column layout: the root walks along x at
/// 0.02 m/frame at 0.95 m height, root and ball exp maps are (1.5, 0.05, 0.1) rad, joint exp
/// maps are small (≤ 0.12 rad), body positions drift by 0.01 m/frame, the contact label
/// alternates 0, 1, 0, … . Every row passes [`crate::validate`] at 60 fps.
pub fn synthetic_rows(t: usize) -> Vec<f32> {
    let mut rows = vec![0.0f32; t * PT_WIDTH];
    for (f, r) in rows.chunks_exact_mut(PT_WIDTH).enumerate() {
        r[0..3].copy_from_slice(&[0.02 * f as f32, 1.0, 0.95]);
        r[3..6].copy_from_slice(&[1.5, 0.05, 0.1]);
        r[6..9].copy_from_slice(&[1.5, 0.05, 0.1]);
        for (k, x) in r.iter_mut().enumerate().take(165).skip(9) {
            *x = ((k * 7 + f) % 13) as f32 * 0.01;
        }
        for (k, x) in r.iter_mut().enumerate().take(327).skip(165) {
            *x = (k % 5) as f32 * 0.1 + 0.01 * f as f32;
        }
        r[336] = (f % 2) as f32;
    }
    rows
}

/// A synthetic walking-like SMPL-H sequence in the AMASS `.npz` layout (`poses` (T, 156), `trans`
/// (T, 3), `mocap_framerate`, all float64; `numpy.savez` layout): upright (root Rx(90°) in the Z-up
/// world) turning slowly about z, walking along the world's facing at 1 m/s at pelvis height
/// 0.95 m, hips and knees swinging (±0.5 rad, 0–0.9 rad at 1 Hz), arms counter-swinging, fingers
/// curled a little; `betas` stored as given. Returns `poses` for checks.
pub fn write_synthetic_amass(
    path: &std::path::Path,
    frames: usize,
    fps: f64,
    betas: &[f64],
) -> std::io::Result<Vec<f64>> {
    use skillmimic_core::math::Quat;
    let mut poses = vec![0.0f64; frames * 156];
    let mut trans = vec![0.0f64; frames * 3];
    for f in 0..frames {
        let t = f as f64 / fps;
        let yaw = 0.3 * t;
        let root = Quat::about_z(yaw)
            .mul(Quat::from_axis_angle([1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_2));
        let row = &mut poses[f * 156..(f + 1) * 156];
        row[0..3].copy_from_slice(&root.to_rotvec());
        let s = (2.0 * std::f64::consts::PI * t).sin();
        let set =
            |row: &mut [f64], j: usize, v: [f64; 3]| row[3 * j..3 * j + 3].copy_from_slice(&v);
        set(row, 1, [0.5 * s, 0.0, 0.0]); // left hip
        set(row, 2, [-0.5 * s, 0.0, 0.0]); // right hip
        set(row, 4, [0.45 * (1.0 + s), 0.0, 0.0]); // left knee
        set(row, 5, [0.45 * (1.0 - s), 0.0, 0.0]); // right knee
        set(row, 16, [0.0, 0.0, -1.2]); // shoulders down from the T-pose
        set(row, 17, [0.0, 0.0, 1.2]);
        set(row, 18, [0.0, -0.3 - 0.2 * s, 0.0]); // elbows
        set(row, 19, [0.0, 0.3 - 0.2 * s, 0.0]);
        for j in 22..52 {
            set(row, j, [0.0, 0.0, 0.2]);
        }
        // facing: the body's +z turned by the root; walk along its horizontal part
        let fwd = root.rotate([0.0, 0.0, 1.0]);
        let p = [fwd[0] * t, fwd[1] * t, 0.95];
        trans[3 * f..3 * f + 3].copy_from_slice(&p);
    }
    write_npz(
        path,
        &[
            ("poses", &[frames, 156], &poses),
            ("trans", &[frames, 3], &trans),
            ("mocap_framerate", &[], &[fps]),
            ("betas", &[betas.len()], betas),
        ],
    )?;
    Ok(poses)
}

/// Write float64 arrays as a `numpy.savez` archive (`name.npy` entries, C order, stored).
pub fn write_npz(
    path: &std::path::Path,
    arrays: &[(&str, &[usize], &[f64])],
) -> std::io::Result<()> {
    fn npy(shape: &[usize], v: &[f64]) -> Vec<u8> {
        let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
        let shape_txt = match dims.len() {
            0 => "()".to_string(),
            1 => format!("({},)", dims[0]),
            _ => format!("({})", dims.join(", ")),
        };
        let mut header =
            format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape_txt}, }}");
        while (10 + header.len() + 1) % 64 != 0 {
            header.push(' ');
        }
        header.push('\n');
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend_from_slice(&(header.len() as u16).to_le_bytes());
        out.extend_from_slice(header.as_bytes());
        for x in v {
            out.extend_from_slice(&x.to_le_bytes());
        }
        out
    }
    let mut zip = zip::ZipWriter::new(std::fs::File::create(path)?);
    let opts =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    for (name, shape, v) in arrays {
        zip.start_file(format!("{name}.npy"), opts).map_err(std::io::Error::other)?;
        std::io::Write::write_all(&mut zip, &npy(shape, v))?;
    }
    zip.finish().map_err(std::io::Error::other)?;
    Ok(())
}
