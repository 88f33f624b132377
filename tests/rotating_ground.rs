//! A spatial ground with all six components of motion (x, y, z and rotations rx, ry, rz,
//! R = Rz(rz) Ry(ry) Rx(rx)): a body welded to it by a `fixed` joint must follow it
//! exactly. Closed form: a point p of the body, welded at anchor a of the ground with the
//! frames aligned, is at r_g(t) + R_g(t) (a + p) in the world and at a + p in the ground's
//! axes, at every time. Checks the constraint Φ, its bias b (the motion is followed to
//! the integration tolerance only if b carries the ground's angular acceleration), the
//! start at rest relative to the turning ground, and the `_rel` responses.

use std::process::Command;

const MODEL: &str = r#"
[model]
name = "welded to a rotating table"
forcing_frequency = "w"

[parameters]
w = { value = 5, unit = "rad/s" }
X = { value = 0.01, unit = "m" }
Z = { value = 0.02, unit = "m" }
A = { value = 0.1 }
B = { value = 0.05 }
C = { value = 0.2 }

[ground]
motion = { x = "X*sin(w*t)", z = "Z*sin(2*w*t)", rx = "A*sin(w*t)", ry = "B*cos(w*t)", rz = "C*sin(w*t + 0.3)" }

[[bodies]]
name = "b"
rotation = [["z", "a"], ["y", "c"], ["x", "d"]]
mass = 2
cg = [0.1, 0, 0]
inertia = [0.01, 0.02, 0.025]
x = 0.4
y = 0.1
z = 0.2
points = { tip = [0.5, 0.2, -0.1] }

[[joints]]
name = "weld"
type = "fixed"
body1 = "b"
point1 = [0, 0, 0]
body2 = "ground"
point2 = [0.3, 0.1, 0.2]

[[forces]]
type = "gravity"
acceleration = [0, -9.81, 0]
"#;

fn rx(a: f64) -> [[f64; 3]; 3] {
    let (s, c) = a.sin_cos();
    [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
}
fn ry(a: f64) -> [[f64; 3]; 3] {
    let (s, c) = a.sin_cos();
    [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
}
fn rz(a: f64) -> [[f64; 3]; 3] {
    let (s, c) = a.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}
fn mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

#[test]
fn a_body_welded_to_a_rotating_translating_ground_follows_it() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.toml"), MODEL).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(dir.path())
        .args([
            "simulate",
            "m.toml",
            "--t-end",
            "2",
            "--dt-out",
            "0.01",
            "-o",
            "out.csv",
            "--response",
            "b.tip.x",
            "--response",
            "b.tip.y",
            "--response",
            "b.tip.z",
            "--response",
            "b.tip.x_rel",
            "--response",
            "b.tip.y_rel",
            "--response",
            "b.tip.z_rel",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(dir.path().join("out.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (ct, cx) = (col("t"), col("b.tip.x"));
    let crel = col("b.tip.x_rel");
    let (w, xa, za, a, b, c) = (5.0f64, 0.01, 0.02, 0.1, 0.05, 0.2);
    let local = [0.3 + 0.5, 0.1 + 0.2, 0.2 - 0.1];
    let mut worst = (0.0f64, 0.0f64);
    let mut rows = 0;
    for line in lines {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let t = v[ct];
        let r = mul(
            &mul(&rz(c * (w * t + 0.3).sin()), &ry(b * (w * t).cos())),
            &rx(a * (w * t).sin()),
        );
        let rg = [xa * (w * t).sin(), 0.0, za * (2.0 * w * t).sin()];
        for k in 0..3 {
            let want: f64 = rg[k] + (0..3).map(|j| r[k][j] * local[j]).sum::<f64>();
            worst.0 = worst.0.max((v[cx + k] - want).abs());
            worst.1 = worst.1.max((v[crel + k] - local[k]).abs());
        }
        rows += 1;
    }
    assert_eq!(rows, 201);
    assert!(worst.0 < 1e-9, "world position off by {:.3e} m", worst.0);
    assert!(
        worst.1 < 1e-9,
        "position in the ground's axes off by {:.3e} m",
        worst.1
    );
}
