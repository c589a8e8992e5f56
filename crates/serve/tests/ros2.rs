//! ROS 2 (feature `ros2`): a subscriber on loopback receives the server's poses as
//! `geometry_msgs/PoseWithCovarianceStamped`.

mod common;

use futures_util::StreamExt;
use ros2_client::{Context, NodeName, NodeOptions};
use serve::ros2::{PoseWithCovarianceStamped, message_type, qos, topic_name};
use std::time::Duration;

#[test]
fn a_ros2_subscriber_receives_the_poses() -> Result<(), Box<dyn std::error::Error>> {
    let pipeline = common::pipeline(400, 20.0, false);
    let hub = serve::Hub::new(pipeline.metrics(), serve::FloorMap::default());
    let topic = "/indoorloc_test/pose";
    let _publisher = serve::ros2::Publisher::start(&hub, topic)?;

    let ctx = Context::new()?;
    let mut node = ctx.new_node(
        NodeName::new("/indoorloc_test", "listener")?,
        NodeOptions::new(),
    )?;
    let t = node.create_topic(&topic_name(topic)?, message_type(), &qos())?;
    let sub = node.create_subscription::<PoseWithCovarianceStamped>(&t, None)?;
    let spinner = node.spinner()?;

    let feeder = {
        let hub = std::sync::Arc::clone(&hub);
        std::thread::spawn(move || {
            pipeline.run(|e, f| hub.publish(e, f));
        })
    };
    let ex = smol::LocalExecutor::new();
    ex.spawn(spinner.spin()).detach();
    let got = smol::block_on(ex.run(async {
        let mut stream = Box::pin(sub.async_stream());
        let mut got = Vec::new();
        let wait = async {
            while let Some(Ok((m, _))) = stream.next().await {
                got.push(m);
                if got.len() >= 5 {
                    break;
                }
            }
        };
        smol::future::or(wait, async {
            smol::Timer::after(Duration::from_secs(20)).await;
        })
        .await;
        got
    }));
    drop(feeder);
    assert!(got.len() >= 5, "received {} poses", got.len());
    for m in &got {
        assert_eq!(m.header.frame_id, "map");
        assert!((m.pose.pose.position.y - 1.0).abs() < 0.2, "{m:?}");
        assert!((m.pose.pose.orientation.w - 1.0).abs() < 1e-6);
        // Position variances on the diagonal, rotation variances after them.
        assert!(
            m.pose.covariance[0] > 0.0 && m.pose.covariance[35] > 0.0,
            "{:?}",
            m.pose.covariance
        );
        assert!(m.header.stamp.sec > 1_700_000_000);
    }
    Ok(())
}
