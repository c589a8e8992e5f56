//! ROS 2 output (feature `ros2`): every fused pose published as
//! `geometry_msgs/PoseWithCovarianceStamped`, through the pure-Rust DDS of `ros2-client`, so
//! no ROS installation is needed and ROS 2 nodes on the network (or loopback) receive it.
//!
//! The message types are defined here as serde structs in ROS 2's CDR field order: ros2-client
//! ships no message definitions.

use crate::hub::Hub;
use ros2_client::{
    Context, MessageTypeName, Name, NodeName, NodeOptions, QosProfile,
    qos::{Durability, History, WhenFull},
};
use serde::{Deserialize, Serialize};
use std::time::{SystemTime, UNIX_EPOCH};
use track::PoseEvent;

/// `builtin_interfaces/Time`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds since the epoch.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

/// `std_msgs/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// When the pose was made.
    pub stamp: Time,
    /// The frame the pose is in.
    pub frame_id: String,
}

/// `geometry_msgs/Point`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// Metres.
    pub x: f64,
    /// Metres.
    pub y: f64,
    /// Metres.
    pub z: f64,
}

/// `geometry_msgs/Quaternion` (ROS order: x, y, z, w).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

/// `geometry_msgs/Pose`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Camera centre.
    pub position: Point,
    /// Camera-to-world rotation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/PoseWithCovariance`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Row-major 6x6 covariance of (x, y, z, rotation about x, y, z).
    #[serde(with = "array36")]
    pub covariance: [f64; 36],
}

/// `geometry_msgs/PoseWithCovarianceStamped`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovarianceStamped {
    /// Stamp and frame.
    pub header: Header,
    /// Pose and covariance.
    pub pose: PoseWithCovariance,
}

impl ros2_client::Message for PoseWithCovarianceStamped {}

/// serde derives arrays up to 32 elements; a fixed CDR array of 36 is the same bytes as two of
/// 18 (no length prefix either way).
mod array36 {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(a: &[f64; 36], s: S) -> Result<S::Ok, S::Error> {
        let mut h = [0.0; 18];
        let mut t = [0.0; 18];
        h.copy_from_slice(&a[..18]);
        t.copy_from_slice(&a[18..]);
        (h, t).serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 36], D::Error> {
        let (h, t) = <([f64; 18], [f64; 18])>::deserialize(d)?;
        let mut a = [0.0; 36];
        a[..18].copy_from_slice(&h);
        a[18..].copy_from_slice(&t);
        Ok(a)
    }
}

impl PoseWithCovarianceStamped {
    /// The ROS message of a fused pose, stamped now, in frame `frame_id`.
    pub fn of(p: &PoseEvent, frame_id: &str) -> PoseWithCovarianceStamped {
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default();
        let [w, x, y, z] = p.quaternion;
        let mut covariance = [0.0; 36];
        for r in 0..3 {
            for c in 0..3 {
                covariance[r * 6 + c] = p.covariance_pos[r * 3 + c];
            }
        }
        // sigma_rot_deg is the RMS angle, the root of the three axes' variances together.
        let rot_var = p.sigma_rot_deg.to_radians().powi(2) / 3.0;
        for k in 3..6 {
            covariance[k * 6 + k] = rot_var;
        }
        PoseWithCovarianceStamped {
            header: Header {
                stamp: Time {
                    sec: i32::try_from(now.as_secs()).unwrap_or(i32::MAX),
                    nanosec: now.subsec_nanos(),
                },
                frame_id: frame_id.to_string(),
            },
            pose: PoseWithCovariance {
                pose: Pose {
                    position: Point {
                        x: p.position[0],
                        y: p.position[1],
                        z: p.position[2],
                    },
                    orientation: Quaternion { x, y, z, w },
                },
                covariance,
            },
        }
    }
}

/// The ROS type name of the message.
pub fn message_type() -> MessageTypeName {
    MessageTypeName::new("geometry_msgs", "PoseWithCovarianceStamped")
}

/// The QoS of the pose topic: reliable, the last few poses kept.
pub fn qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

/// A topic name (`/indoorloc/pose`) as ros2-client takes it.
///
/// # Errors
/// Not a valid ROS name.
pub fn topic_name(topic: &str) -> Result<Name, String> {
    Name::parse(topic).map_err(|e| format!("ROS 2 topic '{topic}': {e}"))
}

/// Publishes the hub's poses while it lives (a DDS participant, a node and its spinner on a
/// thread of their own).
pub struct Publisher {
    _thread: std::thread::JoinHandle<()>,
}

impl Publisher {
    /// Starts publishing every pose of `hub` on `topic`, in frame `map`.
    ///
    /// # Errors
    /// A bad topic name, or DDS cannot start (no network interface).
    pub fn start(hub: &Hub, topic: &str) -> Result<Publisher, String> {
        let name = topic_name(topic)?;
        let ctx = Context::new().map_err(|e| format!("ROS 2: cannot start DDS: {e}"))?;
        let node_name =
            NodeName::new("/indoorloc", "serve").map_err(|e| format!("ROS 2 node name: {e}"))?;
        let mut node = ctx
            .new_node(node_name, NodeOptions::new())
            .map_err(|e| format!("ROS 2: cannot make the node: {e}"))?;
        let t = node
            .create_topic(&name, message_type(), &qos())
            .map_err(|e| format!("ROS 2 topic '{topic}': {e}"))?;
        let publisher = node
            .create_publisher::<PoseWithCovarianceStamped>(&t, None)
            .map_err(|e| format!("ROS 2 publisher on '{topic}': {e}"))?;
        let spinner = node
            .spinner()
            .map_err(|e| format!("ROS 2: cannot spin the node: {e}"))?;
        // Poses wait here for the DDS thread; a full buffer drops the pose (a stale pose is
        // worth nothing to a robot).
        let (tx, rx) = smol::channel::bounded::<PoseEvent>(16);
        hub.tap(move |p| {
            let _ = tx.try_send(p.clone());
        });
        let thread = std::thread::spawn(move || {
            let _keep = (ctx, node);
            let ex = smol::LocalExecutor::new();
            ex.spawn(spinner.spin()).detach();
            smol::block_on(ex.run(async move {
                while let Ok(p) = rx.recv().await {
                    // Publishing fails only when DDS is going down; then stop.
                    if publisher
                        .async_publish(PoseWithCovarianceStamped::of(&p, "map"))
                        .await
                        .is_err()
                    {
                        break;
                    }
                }
            }));
        });
        Ok(Publisher { _thread: thread })
    }
}
