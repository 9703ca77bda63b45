//! Animations of a run: `d.movie_every(steps, field, name)` writes `name.gif`, an animated GIF
//! decoded here frame by frame — its frame count and size, frames that change as the grains
//! fall, one colour scale over all frames, PNG frames where asked, the run page showing it,
//! the GIF of a run stopped by SIGTERM and continued by `--resume`, and bad arguments refused
//! with what to do.

use crate::common::{bin, run_script, stderr, stdout, temp_dir, terminate_after_first_line_in};
use std::path::Path;

/// Grains falling in a small box under raised gravity.
const FALL: &str = r#"
let b = new_box("tiny");
b.ball_r = 0.5e-3; b.distri_rate = 0.2;
b.sample_w = 4e-3; b.sample_l = 4e-3; b.sample_h = 5e-3;
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("grain", #{ kn: 2e4, ks: 8e3, xb: 1e-4, fs0: 1.0, r: 0.5e-3, mu_p: 0.5 }));
d.set_standard_dt();
d.gravity = [0.0, 0.0, -500.0];
d.local_damping = 0.3;
"#;

/// The frames of a GIF file, decoded: (width, height, each frame's RGBA pixels).
fn decode(path: &Path) -> (u16, u16, Vec<Vec<u8>>) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::RGBA);
    let mut decoder = options.read_info(file).unwrap_or_else(|e| panic!("{}: not a GIF: {e}", path.display()));
    let (w, h) = (decoder.width(), decoder.height());
    let mut frames = Vec::new();
    while let Some(frame) = decoder.read_next_frame().unwrap_or_else(|e| panic!("{}: bad frame: {e}", path.display())) {
        assert_eq!((frame.width, frame.height), (w, h), "every frame covers the picture");
        frames.push(frame.buffer.to_vec());
    }
    (w, h, frames)
}

/// How many pixels of two frames differ.
fn changed(a: &[u8], b: &[u8]) -> usize {
    a.chunks(4).zip(b.chunks(4)).filter(|(p, q)| p != q).count()
}

#[test]
fn a_movie_decodes_with_one_frame_per_period_at_picture_size_and_its_frames_change_as_grains_fall() {
    let dir = temp_dir("movie");
    let script = format!(
        "{FALL}\nd.movie_every(100, \"dz\", \"fall\", #{{ frames_png: true, delay: 0.05, max_frames: 12 }});\nd.run(1000);\n\
         d.balance(500);\nprint(d.movie_end());\nd.run(300);\n"
    );
    let o = run_script(&dir, "fall.rhai", &script, &["--backend", "cpu"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.join("out");
    // A frame every 100 steps of d.run and d.balance alike, 15 in all, of which max_frames
    // keeps 12 and says so; none after movie_end.
    let (w, h, frames) = decode(&out.join("fall.gif"));
    assert_eq!((w, h), (800, 700));
    assert_eq!(frames.len(), 12);
    assert!(stderr(&o).contains("max_frames"), "the cut is said: {}", stderr(&o));
    // Falling grains: every frame differs from the one before, and the last from the first a lot.
    for k in 1..frames.len() {
        assert!(changed(&frames[k - 1], &frames[k]) > 0, "frame {k} is the same as frame {}", k - 1);
    }
    let moved = changed(&frames[0], &frames[11]);
    assert!(moved > 5_000, "only {moved} pixels changed between the first and last frame");
    // The PNG frames, by step; movie_end returned every file it wrote.
    let mut pngs: Vec<String> = std::fs::read_dir(out.join("fall_frames"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    pngs.sort();
    assert_eq!(pngs.len(), 12);
    assert_eq!(pngs[0], "fall_000000100.png");
    assert_eq!(pngs[11], "fall_000001200.png");
    assert!(stdout(&o).contains("fall.gif") && stdout(&o).contains("fall_000001200.png"), "{}", stdout(&o));
    // No spool or temporary left behind; the run's page shows the movie.
    let hidden: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(hidden.iter().all(|n| n.starts_with(".matdem")), "left behind: {hidden:?}");
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains("<img src=\"fall.gif\""), "the page does not show the movie");
}

#[test]
fn a_movie_of_one_falling_grain_repaints_only_that_grain_and_the_title() {
    // Every grain is fixed but the highest, which falls: the still grains keep their colour
    // from the first frame to the last, although the highest z of a frame drops (a scale per
    // frame would stretch over the still grains; the unit test of the scale is in
    // plot::picture).
    let dir = temp_dir("movie-scale");
    let script = format!(
        "{FALL}\nlet still = d.z < d.z.max();\nd.fix(still, \"xyz\");\nd.movie_every(200, \"z\", \"one\");\n\
         d.run(1000);\n"
    );
    let o = run_script(&dir, "one.rhai", &script, &["--backend", "cpu"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (_, _, frames) = decode(&dir.join("out/one.gif"));
    assert_eq!(frames.len(), 5);
    // The falling grain, the title (its step) and nothing else may change colour. (Each
    // frame has its own 256-colour palette, so a colour may shift by a few levels.)
    let clearly = |p: &[u8], q: &[u8]| p.iter().zip(q).any(|(a, b)| a.abs_diff(*b) > 40);
    let moved = frames[0].chunks(4).zip(frames[4].chunks(4)).filter(|(p, q)| clearly(p, q)).count();
    assert!(moved > 0 && moved < 20_000, "{moved} pixels changed: the still grains were repainted");
}

#[test]
fn a_run_stopped_by_sigterm_keeps_a_valid_movie_and_resume_finishes_the_movie_an_uninterrupted_run_makes() {
    // 4 frames, then 100 more in a run of about 4 s, stopped about 0.3 s into it.
    let script = format!(
        "{FALL}\nd.movie_every(6000, \"speed\", \"fall\");\nd.run(24000);\nprint(\"started\");\nd.run(600000);\n"
    );
    let dir = temp_dir("movie-stop");
    let (code, _, record) = terminate_after_first_line_in(&dir, &script, &[]);
    assert_eq!(code, Some(130), "{record}");
    let out = dir.join("out");
    let (_, _, frames) = decode(&out.join("fall.gif"));
    let taken = frames.len();
    assert!((4..104).contains(&taken), "the frames taken before the signal are kept: {taken}");
    assert!(std::fs::read_to_string(out.join("index.html")).unwrap().contains("fall.gif"));
    // The resumed run continues the movie: one GIF of every frame, the very file an
    // uninterrupted run writes (one scale over all the frames, taken on the same steps).
    let o =
        bin().arg("run").arg(dir.join("s.rhai")).arg("--resume").arg(&out).args(["--backend", "cpu"]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let (_, _, frames) = decode(&out.join("fall.gif"));
    assert_eq!(frames.len(), 104);
    let straight = temp_dir("movie-straight");
    let o = run_script(&straight, "s.rhai", &script, &["--backend", "cpu"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        std::fs::read(out.join("fall.gif")).unwrap() == std::fs::read(straight.join("out/fall.gif")).unwrap(),
        "the resumed movie differs from the uninterrupted one"
    );
    assert!(!out.join(".fall.gif.frames").exists(), "the finished run keeps no spool");
}

#[test]
fn bad_movie_arguments_are_refused_with_what_to_do() {
    let calls = [
        ("d.movie_every(0, \"dz\", \"m\")", "steps must be ≥ 1"),
        ("d.movie_every(-5, \"dz\", \"m\")", "steps must be ≥ 1"),
        ("d.movie_every(10, \"dzz\", \"m\")", "unknown particle field `dzz`"),
        ("d.movie_every(10, \"temperature\", \"m\")", "d.enable(\\\"heat\\\")"),
        ("d.movie_every(10, \"dz\", \"../escape\")", "must be letters, digits"),
        ("d.movie_every(10, \"dz\", \"/tmp/abs\")", "must be letters, digits"),
        ("d.movie_every(10, \"dz\", \".hidden\")", "must be letters, digits"),
        ("d.movie_every(10, \"dz\", \"\")", "must be letters, digits"),
        ("d.movie_every(10, \"dz\", \"m\", #{ fps: 10 })", "unknown option `fps`"),
        ("d.movie_every(10, \"dz\", \"m\", #{ range: [1.0, 0.0] })", "lo < hi"),
        ("d.movie_every(10, \"dz\", \"m\", #{ max_frames: 0 })", "max_frames must be"),
        ("d.movie_every(10, \"dz\", \"m\", #{ slice: -1.0 })", "slice is the half-width"),
        ("d.movie_every(10, \"dz\", \"m\", #{ delay: 0.0 })", "delay is the time"),
    ];
    let mut script = FALL.to_string();
    for (call, _) in &calls {
        script.push_str(&format!("try {{ {call}; print(\"accepted\"); }} catch (e) {{ print(`${{e}}`); }}\n"));
    }
    let dir = temp_dir("movie-bad");
    let o = run_script(&dir, "bad.rhai", &script, &["--backend", "cpu"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let printed = stdout(&o);
    let lines: Vec<&str> = printed.lines().collect();
    assert_eq!(lines.len(), calls.len(), "{printed}");
    for ((call, expected), line) in calls.iter().zip(&lines) {
        let expected = expected.replace("\\\"", "\"");
        assert!(line.contains("movie_every") && line.contains(&expected), "{call}: {line}");
    }
    // Nothing was written outside the output folder, or into it.
    assert!(!dir.join("escape.gif").exists() && !Path::new("/tmp/abs.gif").exists());
    let out: Vec<String> = std::fs::read_dir(dir.join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".gif") || n.ends_with(".frames"))
        .collect();
    assert!(out.is_empty(), "{out:?}");
    // Two models may not take one movie.
    let two = format!("{FALL}\nlet e = b.build_initial_model();\nd.movie_every(10, \"dz\", \"m\");\ne.movie_every(10, \"dz\", \"m\");\n");
    let o = run_script(&dir, "two.rhai", &two, &["--backend", "cpu"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("already taking the movie `m`"), "{}", stderr(&o));
}
