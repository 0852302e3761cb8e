//! The whole node on a real DDS participant under the Cyclone service mapping, called by many
//! clients whose identities are made as rmw_cyclonedds_cpp makes them: each client has its own
//! request writer and reply reader, and writes its requests with a payload header carrying its
//! 64-bit client id (the request writer's instance handle, an arbitrary number) and a sequence
//! number. Every client must get the reply to its own request, whatever its id.
//!
//! The node runs with `reply_reader_wait_s` = 600: a reply held for a reader that never shows
//! (the client id read as a reader's GUID, what an old gate did for about half of all ids)
//! would not come within the test's run at all; the reply each request waits for — a reader
//! of the reply topic in the client's participant — is there.
//! The clients are a separate RustDDS participant on 127.0.0.1, on a random domain.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::collections::hash_map::RandomState;
use std::collections::BTreeMap;
use std::hash::{BuildHasher, Hasher};
use std::net::{IpAddr, Ipv4Addr};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use fs020n_client::{BoxedStream, ClientConfig, ConnectFuture, Connector, Robot};
use fs020n_ros2::{DdsConfig, NodeConfig, RobotSource, ServiceMapping};
use fs020n_sim::{ControllerConfig, Emulator};
use ros2_client::dds::rustdds::no_key::{DataReader, DataWriter};
use ros2_client::dds::rustdds::policy::{Durability, History, Reliability};
use ros2_client::dds::rustdds::{
    CDRDeserializerAdapter, CDRSerializerAdapter, DomainParticipantBuilder, QosPolicyBuilder,
    TopicKind,
};
use serde::{Deserialize, Serialize};

struct EmuConnector(Arc<Mutex<Emulator>>);

impl Connector for EmuConnector {
    fn connect(&self) -> ConnectFuture<'_> {
        let emu = self.0.lock().expect("emulator").clone();
        Box::pin(async move { Ok(Box::new(emu.connect()?) as BoxedStream) })
    }

    fn describe(&self) -> String {
        "in-memory emulator".into()
    }
}

/// `control_msgs/action/FollowJointTrajectory`'s `get_result` request as rmw_cyclonedds_cpp
/// writes it: its request header (client id, sequence number), then the goal id.
#[derive(Serialize)]
struct CycloneGetResultRequest {
    client_id: [u8; 8],
    seq_high: i32,
    seq_low: u32,
    goal_id: [u8; 16],
}

/// The reply: the same header, then the status and the result (error code and text).
#[derive(Deserialize, Debug)]
struct CycloneGetResultReply {
    client_id: [u8; 8],
    seq_high: i32,
    seq_low: u32,
    status: i8,
    error_code: i32,
    error_string: String,
}

const ACTION: &str = "fs020n_controller/follow_joint_trajectory/_action";

/// A random number (the standard library's per-process random hasher keys).
fn random_u64() -> u64 {
    let mut h = RandomState::new().build_hasher();
    h.write_u64(0x5eed);
    h.finish()
}

/// 24 client ids: 8 with each of the entity-kind bytes a reader has (0x04, 0x07, 0xC4, 0xC7)
/// in the position the old reply gate read, 8 random with the bit 0x04 there, 8 random.
fn client_ids() -> Vec<u64> {
    let mut ids = Vec::new();
    for kind in [0x04u64, 0x07, 0xC4, 0xC7] {
        ids.push(kind << 56 | (random_u64() >> 8));
        ids.push(kind << 56 | 1);
    }
    ids.extend((0..8).map(|_| random_u64() | 0x04 << 56));
    ids.extend((0..8).map(|_| random_u64()));
    ids
}

struct Client {
    id: u64,
    writer: DataWriter<CycloneGetResultRequest, CDRSerializerAdapter<CycloneGetResultRequest>>,
    reader: DataReader<CycloneGetResultReply, CDRDeserializerAdapter<CycloneGetResultReply>>,
    sent: Vec<u32>,
    answered: Option<CycloneGetResultReply>,
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_cyclone_mapping_client_gets_its_own_reply_whatever_its_id() {
    let domain_id = (100 + random_u64() % 130) as u16;
    let emu = Emulator::new(ControllerConfig::default());
    let robot = Robot::connect_with(
        EmuConnector(Arc::new(Mutex::new(emu))),
        ClientConfig::default(),
    )
    .await
    .expect("connect to the emulator");
    let model = robot.model().clone();
    let source: Arc<dyn RobotSource> = Arc::new(Arc::new(robot));
    let config = NodeConfig {
        reply_reader_wait_s: 600.0,
        dds: DdsConfig {
            domain_id,
            localhost_only: true,
            service_mapping: ServiceMapping::Cyclone,
        },
        ..NodeConfig::default()
    };
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let node = tokio::spawn(fs020n_ros2::run(config, model, source, async {
        let _ = stop_rx.await;
    }));

    let participant = DomainParticipantBuilder::new(domain_id)
        .with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)])
        .build()
        .expect("the clients' DDS participant");
    let qos = QosPolicyBuilder::new()
        .reliability(Reliability::Reliable {
            max_blocking_time: ros2_client::dds::rustdds::Duration::from_millis(100),
        })
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
        .build();
    let request_topic = participant
        .create_topic(
            format!("rq/{ACTION}/get_resultRequest"),
            "control_msgs::action::dds_::FollowJointTrajectory_GetResult_Request_".into(),
            &qos,
            TopicKind::NoKey,
        )
        .expect("request topic");
    let reply_topic = participant
        .create_topic(
            format!("rr/{ACTION}/get_resultReply"),
            "control_msgs::action::dds_::FollowJointTrajectory_GetResult_Response_".into(),
            &qos,
            TopicKind::NoKey,
        )
        .expect("reply topic");
    let publisher = participant.create_publisher(&qos).expect("publisher");
    let subscriber = participant.create_subscriber(&qos).expect("subscriber");
    let mut clients: Vec<Client> = client_ids()
        .into_iter()
        .map(|id| Client {
            id,
            // rmw_cyclonedds: the reply reader first, then the request writer.
            reader: subscriber
                .create_datareader_no_key_cdr(&reply_topic, None)
                .expect("reply reader"),
            writer: publisher
                .create_datawriter_no_key_cdr(&request_topic, None)
                .expect("request writer"),
            sent: Vec::new(),
            answered: None,
        })
        .collect();

    // Every client asks for the result of a goal nobody sent, again every 250 ms until it is
    // answered (a request written before the node matched the writer, or a reply written
    // before it matched the reader, is lost on a volatile topic: a client retries, as a
    // MoveIt client waits for the server first). The answer must be STATUS_UNKNOWN (0).
    let goal_id = [0x5a; 16];
    let mut foreign: BTreeMap<u64, usize> = BTreeMap::new();
    for round in 1..=240u32 {
        for c in clients.iter_mut().filter(|c| c.answered.is_none()) {
            let request = CycloneGetResultRequest {
                client_id: c.id.to_le_bytes(),
                seq_high: 0,
                seq_low: round,
                goal_id,
            };
            if c.writer.write(request, None).is_ok() {
                c.sent.push(round);
            }
        }
        tokio::time::sleep(Duration::from_millis(250)).await;
        let ids: Vec<u64> = clients.iter().map(|c| c.id).collect();
        for c in clients.iter_mut() {
            while let Ok(Some(sample)) = c.reader.take_next_sample() {
                let reply = sample.into_value();
                let to = u64::from_le_bytes(reply.client_id);
                assert!(ids.contains(&to), "a reply to no client: {reply:?}");
                if to != c.id {
                    // Another client's reply on the shared reply topic: not ours.
                    *foreign.entry(c.id).or_default() += 1;
                    continue;
                }
                assert_eq!(reply.seq_high, 0, "{reply:?}");
                assert!(
                    c.sent.contains(&reply.seq_low),
                    "client {:#018x}: a reply to a request it never sent: {reply:?}",
                    c.id
                );
                assert_eq!(reply.status, 0, "STATUS_UNKNOWN: {reply:?}");
                assert_eq!(reply.error_code, 0, "{reply:?}");
                assert!(reply.error_string.is_empty(), "{reply:?}");
                c.answered.get_or_insert(reply);
            }
        }
        if clients.iter().all(|c| c.answered.is_some()) {
            break;
        }
    }
    let unanswered: Vec<String> = clients
        .iter()
        .filter(|c| c.answered.is_none())
        .map(|c| format!("{:#018x} ({} requests)", c.id, c.sent.len()))
        .collect();
    assert!(
        unanswered.is_empty(),
        "clients never answered: {unanswered:?}"
    );
    // Every client saw the others' replies on the shared topic and took none as its own.
    assert!(!foreign.is_empty());
    let _ = stop_tx.send(());
    node.await
        .expect("the node task")
        .expect("the node ends cleanly");
}
