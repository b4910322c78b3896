//! `bench scene`: scenes of falling bodies in child processes.

use super::*;

/// A scene of `n` bodies dropped into a 1 m wooden box, physics at `steps_per_second`.
pub fn box_scene(n: usize, seconds: f64, steps_per_second: f64) -> String {
    let mut t = format!("duration = {seconds}\nseed = 3\nsteps_per_second = {steps_per_second}\n[listener]\nposition = [0.0, 0.5, 1.2]\n");
    let wall = |t: &mut String, name: &str, size: [f64; 3], pos: [f64; 3]| {
        t.push_str(&format!(
            "[[body]]\nname = \"{name}\"\nfixed = true\nshape = {{ box = [{}, {}, {}] }}\nmaterial = \"preset:wood\"\ndensity = 700\nposition = [{}, {}, {}]\nmodes = 24\n",
            size[0], size[1], size[2], pos[0], pos[1], pos[2]
        ));
    };
    wall(&mut t, "floor", [1.0, 0.04, 1.0], [0.0, -0.02, 0.0]);
    wall(&mut t, "wall-x0", [0.04, 0.4, 1.0], [-0.52, 0.2, 0.0]);
    wall(&mut t, "wall-x1", [0.04, 0.4, 1.0], [0.52, 0.2, 0.0]);
    wall(&mut t, "wall-z0", [1.0, 0.4, 0.04], [0.0, 0.2, -0.52]);
    wall(&mut t, "wall-z1", [1.0, 0.4, 0.04], [0.0, 0.2, 0.52]);
    let per_layer = 25;
    for i in 0..n {
        let layer = i / per_layer;
        let k = i % per_layer;
        let (x, z) = (-0.36 + 0.18 * (k % 5) as f64, -0.36 + 0.18 * (k / 5) as f64);
        let y = 0.15 + 0.12 * layer as f64;
        let (shape, material, density) = match i % 3 {
            0 => (
                format!("{{ sphere = {} }}", 0.02 + 0.005 * (i % 2) as f64),
                "preset:steel",
                7850,
            ),
            1 => (
                "{ box = [0.05, 0.03, 0.04] }".to_string(),
                "preset:ceramic",
                2400,
            ),
            _ => (
                "{ cylinder = [0.025, 0.06] }".to_string(),
                "preset:wood",
                700,
            ),
        };
        let v = [
            0.3 * ((i * 7 % 5) as f64 - 2.0) / 2.0,
            0.0,
            0.3 * ((i * 3 % 5) as f64 - 2.0) / 2.0,
        ];
        t.push_str(&format!(
            "[[body]]\nname = \"b{i}\"\nshape = {shape}\nmaterial = \"{material}\"\ndensity = {density}\nposition = [{x}, {y}, {z}]\nvelocity = [{}, 0.0, {}]\nrotation = [{}, {}, 0.0]\nmodes = 16\n",
            v[0], v[2], (i * 37 % 90) as f64, (i * 53 % 90) as f64
        ));
    }
    t
}

/// Runs `bench scene` and prints its table (or JSON).
///
/// # Errors
/// A failed case (the message says which).
pub fn run_scene(a: SceneBenchArgs) -> Result<()> {
    let exe = std::env::current_exe().context("locating the resound binary")?;
    let tmp = tempfile::tempdir()?;
    let base = match &a.dir {
        Some(d) => {
            std::fs::create_dir_all(d)?;
            d.clone()
        }
        None => tmp.path().to_path_buf(),
    };
    let dir = &base;
    let counts = a.bodies.clone();
    if counts.is_empty() || counts.iter().any(|&c| c == 0 || c > 2000) || !(a.seconds > 0.0) {
        bail!("--bodies must list counts in 1..=2000 and --seconds must be > 0");
    }
    /// What `resound scene --json` prints.
    #[derive(Serialize, Deserialize)]
    struct SceneJson {
        output: String,
        #[serde(flatten)]
        summary: resound::scene::SceneSummary,
    }
    #[derive(Serialize)]
    struct Case {
        bodies: usize,
        summary: SceneJson,
    }
    #[derive(Serialize)]
    struct Doc {
        benchmark: &'static str,
        seconds: f64,
        steps_per_second: f64,
        #[serde(flatten)]
        realtime_factors: std::collections::BTreeMap<String, f64>,
        peak_rss_mb: f64,
        cases: Vec<Case>,
    }
    let mut realtime_factors = std::collections::BTreeMap::new();
    let mut cases = Vec::new();
    let mut peak = 0.0f64;
    for &n in &counts {
        let scene = dir.join(format!("box{n}.toml"));
        std::fs::write(&scene, box_scene(n, a.seconds, a.steps_per_second))?;
        if !a.json {
            eprintln!("bench scene: {n} bodies, {} s ...", a.seconds);
        }
        let o = Command::new(&exe)
            .args(["scene", "--json", "--library"])
            .arg(dir.join("lib.sqlite"))
            .arg("--cache")
            .arg(dir.join("cache"))
            .arg("-o")
            .arg(dir.join(format!("box{n}.wav")))
            .arg(&scene)
            .output()
            .context("running resound scene")?;
        if !o.status.success() {
            bail!(
                "scene with {n} bodies failed: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        let v: SceneJson =
            serde_json::from_slice(&o.stdout).context("parsing the scene summary")?;
        let s = &v.summary;
        let (rtf, rss) = (s.realtime_factor, s.peak_rss_mb);
        peak = peak.max(rss);
        realtime_factors.insert(format!("realtime_factor_{n}"), rtf);
        if !a.json {
            println!(
                "{n:>4} bodies: {rtf:>6.1}x real time (wall {:.2} s: physics {:.2} s beside sound {:.2} s, for {} s), {} impacts, {} voices at most, build {:.1} s, peak {rss:.0} MB",
                s.simulate_s,
                s.physics_s,
                s.audio_s,
                a.seconds,
                s.impacts,
                s.max_voices,
                s.build_s,
            );
        }
        cases.push(Case {
            bodies: n,
            summary: v,
        });
    }
    let out = Doc {
        benchmark: "scene",
        seconds: a.seconds,
        steps_per_second: a.steps_per_second,
        realtime_factors,
        peak_rss_mb: peak,
        cases,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    }
    Ok(())
}
