//! Pictures from the command line: each command's picture is decoded and checked for
//! its size and for pixels of the expected colours at the pixels the plotting code
//! maps known world coordinates to (through the library's public `Frame`).

use std::path::{Path, PathBuf};

use cliff::eval::person_seed;
use cliff::eval::protocol::{Case, Protocol, Settings, prepare};
use cliff::map::CliffMap;
use cliff::plot::{
    CurveRun, CurvesStyle, Extent, Floorplan, Frame, MapStyle, OBSERVED, PixelRect, SAMPLE, TRUTH,
    curves_layout, direction_colour, hue_saturation, read_summary,
};
use cliff::predict::{Params, TrajectoryBatch, predict};
use cliff::tracks::scene::{SceneOptions, demo_tracks, tracks_csv};
use cliff::tracks::{Format, read_tracks};
use glam::DVec2;
use image::RgbImage;

#[path = "../common/mod.rs"]
mod common;
use common::{cliff, data};

mod curves;
mod demo;
mod map;
mod pixels;
mod prediction;
use pixels::*;

fn ok(args: &[&str]) -> String {
    let o = cliff(args);
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "cliff {args:?} failed: {}{stdout}",
        String::from_utf8_lossy(&o.stderr)
    );
    stdout
}

fn fails(args: &[&str]) -> String {
    let o = cliff(args);
    assert!(!o.status.success(), "cliff {args:?} should fail");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cliff-plot-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn write_summary(dir: &Path, text: &str) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let p = dir.join("summary.csv");
    std::fs::write(&p, text).unwrap();
    p
}
