//! `cliff plot map`: arrows of the demo hall and of THÖR1 over its floor plan.

use super::*;

#[test]
fn map_of_the_demo_hall_has_arrows_coloured_by_direction_and_weight() {
    let dir = tmp("map");
    let out = dir.join("map.png");
    let stdout = ok(&["plot", "map", "--width", "900", "--out", s(&out)]);
    assert!(stdout.contains("315 locations, 728 components"), "{stdout}");
    let img = decode(&out);
    let frame = Frame::for_map(Floorplan::demo_extent(), 900);
    assert_eq!(img.dimensions(), frame.size);
    let at = |x: f64, y: f64| frame.to_pixel(DVec2::new(x, y));
    let (east, north, west, south) = (
        hue_saturation(direction_colour(0.0)).0,
        hue_saturation(direction_colour(std::f64::consts::FRAC_PI_2)).0,
        hue_saturation(direction_colour(std::f64::consts::PI)).0,
        hue_saturation(direction_colour(3.0 * std::f64::consts::FRAC_PI_2)).0,
    );
    // The east-west corridor: an east arrow (red) right of each location, a west
    // arrow (cyan) left of it.
    for x in [-12.0, -8.0, 9.0] {
        for y in [-2.0, 2.0] {
            let e = saturation_of_hue(&img, at(x + 0.2, y), 2, east);
            let w = saturation_of_hue(&img, at(x - 0.2, y), 2, west);
            assert!(e > 0.3 && w > 0.3, "({x}, {y}): east {e}, west {w}");
            // nothing pointing west right of the location
            assert!(saturation_of_hue(&img, at(x + 0.2, y), 2, west) < 0.05);
        }
        // Opacity follows the weight: eastbound walkers keep to the south half (east
        // weight 0.57 at y = -2, 0.43 at y = 2), westbound to the north half.
        let e_south = saturation_of_hue(&img, at(x + 0.2, -2.0), 2, east);
        let e_north = saturation_of_hue(&img, at(x + 0.2, 2.0), 2, east);
        assert!(
            e_south > e_north + 0.05,
            "east arrows {e_south} vs {e_north}"
        );
        let w_south = saturation_of_hue(&img, at(x - 0.2, -2.0), 2, west);
        let w_north = saturation_of_hue(&img, at(x - 0.2, 2.0), 2, west);
        assert!(
            w_north > w_south + 0.05,
            "west arrows {w_north} vs {w_south}"
        );
    }
    // The north-south corridor: north arrows above the locations, south below.
    for y in [-7.0, 6.0] {
        let n = saturation_of_hue(&img, at(1.0, y + 0.2), 2, north);
        let so = saturation_of_hue(&img, at(1.0, y - 0.2), 2, south);
        assert!(n > 0.3 && so > 0.3, "(1, {y}): north {n}, south {so}");
        assert!(saturation_of_hue(&img, at(1.0, y + 0.2), 2, east) < 0.05);
    }
    // The demo floor: grey outside the corridors, white between the arrows.
    for (x, y) in [(-10.0, 7.0), (10.0, -7.0)] {
        let (r, g, b) = px(&img, at(x, y)).unwrap();
        assert!(r == g && g == b && r < 200, "({x}, {y}) is {:?}", (r, g, b));
    }
    assert_eq!(px(&img, at(-9.5, -2.5)), Some((255, 255, 255)));
    // --min-weight leaves out the weaker components: at y = 2 the east weight is 0.43.
    let thin = dir.join("thin.png");
    ok(&[
        "plot",
        "map",
        "--width",
        "900",
        "--min-weight",
        "0.5",
        "--out",
        s(&thin),
    ]);
    let thin = decode(&thin);
    for x in [-12.0, 9.0] {
        assert!(saturation_of_hue(&thin, at(x + 0.2, 2.0), 2, east) < 0.05);
        assert!(saturation_of_hue(&thin, at(x - 0.2, 2.0), 2, west) > 0.3);
        assert!(saturation_of_hue(&thin, at(x + 0.2, -2.0), 2, east) > 0.3);
    }
    // The title is drawn with the embedded font: dark pixels above the plotting area.
    let title_ink = (0..frame.area.top)
        .flat_map(|y| (0..frame.size.0 as i32).map(move |x| (x, y)))
        .filter(|&p| px(&img, p).is_some_and(|(r, _, _)| r < 100))
        .count();
    assert!(title_ink > 150, "title ink {title_ink}");
    // Outside the plotting area, left of it: white margin or black labels, no colour.
    let margin = px(&img, (frame.area.left - 30, frame.area.top + 5)).unwrap();
    assert_eq!(hue_saturation(margin).1, 0.0);
}

#[test]
fn map_over_the_thor1_floor_plan_png_and_svg() {
    let dir = tmp("thor1-map");
    let out = dir.join("thor1.png");
    let extent: Extent = "-11,12,-10,13.5".parse().unwrap();
    let map_file = data("thor1/cliffmap.csv");
    let plan_file = data("thor1/floorplan.png");
    ok(&[
        "plot",
        "map",
        "--map",
        &map_file,
        "--floorplan",
        &plan_file,
        "--extent=-11,12,-10,13.5",
        "--no-legend",
        "--out",
        s(&out),
    ]);
    let img = decode(&out);
    let frame = Frame::for_map(extent, 1000);
    assert_eq!(img.dimensions(), frame.size);
    let map = CliffMap::load(&map_file).unwrap();
    let plan = image::open(&plan_file).unwrap().to_luma8();
    let (dark, light) = check_floorplan(&img, &frame, &map, &plan, &extent, 0.5);
    assert!(dark > 100 && light > 20, "dark {dark}, light {light}");
    // Zoomed in on the obstacle, and zoomed out beyond the plan: the plan stays in place.
    for (view, width, step, want) in [
        ("-2,4,-3,3", 500, 0.2, 20),
        ("-20,20,-15,20", 700, 0.5, 100),
    ] {
        let zoom = dir.join("zoom.png");
        ok(&[
            "plot",
            "map",
            "--map",
            &map_file,
            "--floorplan",
            &plan_file,
            "--extent=-11,12,-10,13.5",
            &format!("--view={view}"),
            "--width",
            &width.to_string(),
            "--no-legend",
            "--out",
            s(&zoom),
        ]);
        let img = decode(&zoom);
        let frame = Frame::for_map(view.parse().unwrap(), width);
        assert_eq!(img.dimensions(), frame.size);
        let (dark, light) = check_floorplan(&img, &frame, &map, &plan, &extent, step);
        assert!(
            dark >= want && light >= want / 5,
            "{view}: dark {dark}, light {light}"
        );
        if view.starts_with("-20") {
            // outside the plan's extent: white
            let p = frame.to_pixel(DVec2::new(-15.0, 0.0));
            assert_eq!(px(&img, p), Some((255, 255, 255)));
        }
    }
    // Arrows: at each location with one component, its colour along its direction.
    let mut checked = 0;
    let seconds = MapStyle::default().arrow_seconds_for(&map);
    for loc in map.locations().iter().filter(|l| l.components.len() == 1) {
        let c = loc.components[0];
        let len = c.rho * seconds;
        if len * frame.scale_x() < 6.0 {
            continue; // too short to find its colour beside the location
        }
        // halfway along the arrow
        let tip = loc.position + DVec2::from_angle(c.theta) * 0.5 * len;
        let sat = saturation_of_hue(
            &img,
            frame.to_pixel(tip),
            2,
            hue_saturation(direction_colour(c.theta)).0,
        );
        assert!(
            sat > 0.2,
            "location {} component at {:.2} rad: {sat}",
            loc.position,
            c.theta
        );
        checked += 1;
    }
    assert!(checked > 50, "{checked}");

    // The same picture as SVG: the floor plan is embedded, arrows are coloured paths.
    let svg_out = dir.join("thor1.svg");
    ok(&[
        "plot",
        "map",
        "--map",
        &map_file,
        "--floorplan",
        &plan_file,
        "--extent=-11,12,-10,13.5",
        "--out",
        s(&svg_out),
    ]);
    let svg = std::fs::read_to_string(&svg_out).unwrap();
    assert!(svg.starts_with("<svg"));
    assert!(svg.contains(&format!(
        r#"width="{}" height="{}""#,
        frame.size.0, frame.size.1
    )));
    assert_eq!(svg.matches("data:image/png;base64,").count(), 1);
    // one shaft (polyline) and one head (polygon) per component
    assert!(
        svg.matches("<polygon").count() >= 527,
        "{}",
        svg.matches("<polygon").count()
    );
    let (r, g, b) = direction_colour(map.locations()[0].components[0].theta);
    assert!(svg.contains(&format!("#{r:02X}{g:02X}{b:02X}")));
}

/// Where the floor plan is black (walls, outside) the picture is the faded grey, where
/// it is white the picture is white: checked on a grid of `step` over the frame's view
/// at points farther than 0.4 m from any map location (the arrows are shorter) and where the
/// plan is uniform around the point (so that scaling does not blur it). Returns the
/// numbers of dark and light points checked.
fn check_floorplan(
    img: &RgbImage,
    frame: &Frame,
    map: &CliffMap,
    plan: &image::GrayImage,
    extent: &Extent,
    step: f64,
) -> (usize, usize) {
    let (w, h) = plan.dimensions();
    let (mut dark, mut light) = (0, 0);
    let v = frame.extent;
    let nx = (v.width() / step) as usize;
    let ny = (v.height() / step) as usize;
    for iy in 0..ny {
        for ix in 0..nx {
            let p = DVec2::new(
                v.x0 + step * (ix as f64 + 0.5),
                v.y0 + step * (iy as f64 + 0.5),
            );
            if map.nearest(p, 0.4).is_some() {
                continue;
            }
            let col = |x: f64| ((x - extent.x0) / extent.width() * w as f64) as i64;
            let row = |y: f64| ((extent.y1 - y) / extent.height() * h as f64) as i64;
            let mut vals = vec![];
            for d in [-0.1, 0.0, 0.1] {
                for e in [-0.1, 0.0, 0.1] {
                    let (c, r) = (col(p.x + d), row(p.y + e));
                    if (0..w as i64).contains(&c) && (0..h as i64).contains(&r) {
                        vals.push(plan.get_pixel(c as u32, r as u32)[0]);
                    }
                }
            }
            if vals.len() < 9 {
                continue;
            }
            let pix = px(img, frame.to_pixel(p)).unwrap();
            if vals.iter().all(|&v| v < 20) {
                dark += 1;
                assert!(pix.0 < 190 && pix.0 > 140 && pix.0 == pix.2, "{p}: {pix:?}");
            } else if vals.iter().all(|&v| v > 235) {
                light += 1;
                assert!(pix.0 > 245 && pix.1 > 245 && pix.2 > 245, "{p}: {pix:?}");
            }
        }
    }
    (dark, light)
}
