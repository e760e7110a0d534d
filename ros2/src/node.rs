//! The ROS 2 side: a DDS participant (RustDDS through ros2-client), the people and
//! tracked-objects subscriptions, the three publishers, and the loop that drives the
//! [`Engine`].

use std::time::{Duration, Instant};

use anyhow::{Context as _, Result};
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::{
    Context, ContextOptions, MessageTypeName, Name, NodeName, NodeOptions, QosProfile,
    qos::{Durability, History, WhenFull},
};

use crate::engine::Engine;
use crate::markers::{self, MarkerStyle};
use crate::msg::{
    self, MarkerArray, OccupancyGrid, People, PredictedObjects, Predictions, Shared, TrackedObjects,
};
use crate::observer::Observer;
use crate::predictor::{Link, Predictor};
use crate::settings::{Parameters, Settings};
use crate::tracks::Keeper;

/// The absolute name of topic `name` in `namespace` (a relative name resolves in it).
pub fn resolve(namespace: &str, name: &str) -> String {
    if name.starts_with('/') {
        name.to_string()
    } else {
        format!("{}/{name}", namespace.trim_end_matches('/'))
    }
}

fn topic_name(full: &str) -> Result<Name> {
    Name::parse(full).map_err(|e| anyhow::anyhow!("topic name '{full}': {e:?}"))
}

fn type_name((pkg, ty): msg::TypeName) -> MessageTypeName {
    MessageTypeName::new(pkg, ty)
}

/// The engine of a node with parameters `p`: its keeper, predictor (in-process, or the
/// cliffd of this host or, over zenoh, of another), markers, grid and observer.
pub fn engine(p: &Parameters) -> Result<Engine> {
    let predictor = Predictor::new(&p.source(), p.predict())?;
    let style = MarkerStyle {
        width: p.marker_width,
        lifetime: p.marker_lifetime,
        z: 0.0,
    };
    let mut engine = Engine::new(
        Keeper::new(p.keeper()),
        predictor,
        style,
        Duration::from_secs_f64(p.warn_period),
    );
    engine.set_object_paths(p.object_paths);
    if p.grid {
        engine.set_grid(Some(crate::grid::GridBuilder::new(p.grid_settings()?)));
    }
    if p.observe {
        engine = engine.with_observer(Observer::new(&p.daemon_map, p.max_tracks)?);
    }
    Ok(engine)
}

/// Run the node until the process is stopped. `domain_id`: the DDS domain.
pub fn run(settings: Settings, domain_id: u16) -> Result<()> {
    let p = &settings.params;
    let mut engine = engine(p)?;
    let map_for_markers = match engine.predictor().local_maps() {
        Some(set) => Some(set.all_day().clone()),
        None if !p.map_markers_file.is_empty() => Some(std::sync::Arc::new(
            cliff::map::CliffMap::load(&p.map_markers_file)
                .with_context(|| format!("loading map_markers_file {}", p.map_markers_file))?,
        )),
        None => None,
    };

    let context = Context::with_options(ContextOptions::new().domain_id(domain_id))
        .map_err(|e| anyhow::anyhow!("DDS participant on domain {domain_id}: {e:?}"))?;
    let mut node = context
        .new_node(
            NodeName::new(&settings.namespace, &settings.name).map_err(|e| {
                anyhow::anyhow!(
                    "node name '{}' in '{}': {e:?}",
                    settings.name,
                    settings.namespace
                )
            })?,
            NodeOptions::new().enable_rosout(false),
        )
        .map_err(|e| anyhow::anyhow!("creating the node: {e:?}"))?;

    let input_qos = if p.best_effort()? {
        QosProfile::subscription_default().history(History::KeepLast { depth: 10 })
    } else {
        QosProfile::subscription_default()
            .reliability_reliable(WhenFull::DEFAULT)
            .history(History::KeepLast { depth: 10 })
    };
    let out_qos = QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(5)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 2 });
    let latched = QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 });

    let t: std::collections::BTreeMap<&str, String> = settings
        .topics
        .iter()
        .map(|(k, v)| (*k, resolve(&settings.namespace, v)))
        .collect();
    let t = &t;
    let people_topic = node
        .create_topic(
            &topic_name(&t["people"])?,
            type_name(msg::PEOPLE),
            &input_qos,
        )
        .map_err(|e| anyhow::anyhow!("topic {}: {e:?}", t["people"]))?;
    let mut people_sub = node
        .create_subscription::<People>(&people_topic, None)
        .map_err(|e| anyhow::anyhow!("subscribing {}: {e:?}", t["people"]))?;
    let objects_topic = node
        .create_topic(
            &topic_name(&t["tracked_objects"])?,
            type_name(msg::TRACKED_OBJECTS),
            &input_qos,
        )
        .map_err(|e| anyhow::anyhow!("topic {}: {e:?}", t["tracked_objects"]))?;
    let mut objects_sub = node
        .create_subscription::<TrackedObjects>(&objects_topic, None)
        .map_err(|e| anyhow::anyhow!("subscribing {}: {e:?}", t["tracked_objects"]))?;
    let pred_topic = node
        .create_topic(
            &topic_name(&t["predictions"])?,
            type_name(msg::PREDICTIONS),
            &out_qos,
        )
        .map_err(|e| anyhow::anyhow!("topic {}: {e:?}", t["predictions"]))?;
    let pred_pub = node
        .create_publisher::<Shared<Predictions>>(&pred_topic, None)
        .map_err(|e| anyhow::anyhow!("publisher {}: {e:?}", t["predictions"]))?;
    let marker_topic = node
        .create_topic(
            &topic_name(&t["markers"])?,
            type_name(msg::MARKER_ARRAY),
            &out_qos,
        )
        .map_err(|e| anyhow::anyhow!("topic {}: {e:?}", t["markers"]))?;
    let marker_pub = node
        .create_publisher::<Shared<MarkerArray>>(&marker_topic, None)
        .map_err(|e| anyhow::anyhow!("publisher {}: {e:?}", t["markers"]))?;
    let objects_out_topic = node
        .create_topic(
            &topic_name(&t["objects"])?,
            type_name(msg::PREDICTED_OBJECTS),
            &out_qos,
        )
        .map_err(|e| anyhow::anyhow!("topic {}: {e:?}", t["objects"]))?;
    let objects_pub = node
        .create_publisher::<Shared<PredictedObjects>>(&objects_out_topic, None)
        .map_err(|e| anyhow::anyhow!("publisher {}: {e:?}", t["objects"]))?;
    let grid_topic = node
        .create_topic(
            &topic_name(&t["occupancy"])?,
            type_name(msg::OCCUPANCY_GRID),
            &latched,
        )
        .map_err(|e| anyhow::anyhow!("topic {}: {e:?}", t["occupancy"]))?;
    let grid_pub = node
        .create_publisher::<Shared<OccupancyGrid>>(&grid_topic, None)
        .map_err(|e| anyhow::anyhow!("publisher {}: {e:?}", t["occupancy"]))?;
    let map_topic = node
        .create_topic(
            &topic_name(&t["map_markers"])?,
            type_name(msg::MARKER_ARRAY),
            &latched,
        )
        .map_err(|e| anyhow::anyhow!("topic {}: {e:?}", t["map_markers"]))?;
    let map_pub = node
        .create_publisher::<MarkerArray>(&map_topic, None)
        .map_err(|e| anyhow::anyhow!("publisher {}: {e:?}", t["map_markers"]))?;
    if let Some(map) = &map_for_markers {
        let arrows = markers::map_arrows(map, &p.map_frame, p.map_arrow_seconds);
        tracing::info!(
            "map: {} arrows on {} (latched)",
            arrows.markers.len() - 1,
            t["map_markers"]
        );
        if let Err(e) = map_pub.publish(arrows) {
            tracing::warn!("publishing the map markers: {e:?}");
        }
    }

    let mut poll = Poll::new().context("mio poll")?;
    poll.registry()
        .register(&mut people_sub, Token(1), Interest::READABLE)
        .context("registering the people subscription")?;
    poll.registry()
        .register(&mut objects_sub, Token(2), Interest::READABLE)
        .context("registering the tracked-objects subscription")?;
    let mut events = Events::with_capacity(16);
    let period = (p.rate > 0.0).then(|| Duration::from_secs_f64(1.0 / p.rate));
    let mut next = Instant::now() + period.unwrap_or(Duration::from_millis(100));
    tracing::info!(
        "node {}{}{} on domain {domain_id}: {}, {} -> {}, {}, {}; predicting {} ({}), k {}, {} s at {} s, {}",
        settings.namespace,
        if settings.namespace.ends_with('/') {
            ""
        } else {
            "/"
        },
        settings.name,
        t["people"],
        t["tracked_objects"],
        t["predictions"],
        t["markers"],
        t["objects"],
        engine.predictor().map_label(),
        if engine.predictor().local_maps().is_some() {
            "in-process".to_string()
        } else {
            let via = match p.link()? {
                Link::SharedMemory => "through cliffd".to_string(),
                Link::Zenoh { endpoints, config } => format!(
                    "through cliffd over zenoh ({})",
                    endpoints
                        .iter()
                        .cloned()
                        .chain(config.map(|c| format!("config {}", c.display())))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            };
            if engine.observer().is_some() {
                format!("{via}, sending it the tracks as observations")
            } else {
                via
            }
        },
        p.k,
        p.horizon,
        p.dt,
        match period {
            Some(d) => format!("every {:.3} s", d.as_secs_f64()),
            None => "on each input".to_string(),
        }
    );

    // handles, not copies: the engine reuses its messages once they are written
    let publish = |out: &crate::engine::Output| {
        if let Some(pr) = out.shared_predictions()
            && let Err(e) = pred_pub.publish(pr)
        {
            tracing::warn!("publishing predictions: {e:?}");
        }
        if let Some(g) = out.shared_grid()
            && let Err(e) = grid_pub.publish(g)
        {
            tracing::warn!("publishing the occupancy grid: {e:?}");
        }
        if let Some(o) = out.shared_objects()
            && let Err(e) = objects_pub.publish(o)
        {
            tracing::warn!("publishing objects: {e:?}");
        }
        if !out.markers().markers.is_empty()
            && let Err(e) = marker_pub.publish(out.shared_markers())
        {
            tracing::warn!("publishing markers: {e:?}");
        }
    };

    loop {
        let timeout = next.saturating_duration_since(Instant::now());
        if let Err(e) = poll.poll(&mut events, Some(timeout))
            && e.kind() != std::io::ErrorKind::Interrupted
        {
            return Err(e).context("poll");
        }
        let mut got = false;
        loop {
            match people_sub.take() {
                Ok(Some((m, _info))) => {
                    engine.on_people(&m, Instant::now());
                    got = true;
                    if period.is_none() {
                        publish(engine.cycle(Instant::now()));
                    }
                }
                Ok(None) => break,
                Err(e) => engine.on_malformed("people", &e.to_string(), Instant::now()),
            }
        }
        loop {
            match objects_sub.take() {
                Ok(Some((m, _info))) => {
                    engine.on_tracked_objects(&m, Instant::now());
                    got = true;
                    if period.is_none() {
                        publish(engine.cycle(Instant::now()));
                    }
                }
                Ok(None) => break,
                Err(e) => engine.on_malformed("tracked_objects", &e.to_string(), Instant::now()),
            }
        }
        let now = Instant::now();
        if now >= next {
            match period {
                Some(d) => {
                    publish(engine.cycle(now));
                    next += d;
                    if next < now {
                        next = now + d;
                    }
                }
                None => {
                    // on-input mode: still forget stale tracks (and delete their markers)
                    if !got && !engine.expire(now).markers.is_empty() {
                        let _ = marker_pub.publish(engine.output().shared_markers());
                    }
                    next = now + Duration::from_millis(100);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_names_resolve_in_the_namespace() {
        assert_eq!(resolve("/", "people"), "/people");
        assert_eq!(resolve("/robot", "cliff/markers"), "/robot/cliff/markers");
        assert_eq!(resolve("/robot/", "people"), "/robot/people");
        assert_eq!(resolve("/robot", "/people"), "/people");
        let n = topic_name("/robot/cliff/markers").unwrap();
        let node = NodeName::new("/robot", "x").unwrap();
        assert_eq!(n.to_dds_name("rt", &node, ""), "rt/robot/cliff/markers");
    }
}
