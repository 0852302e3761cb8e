// A FollowJointTrajectory action client on eProsima Fast DDS (Debian's libfastrtps 2.9), for the
// tests of `fs020n ros2` (pytests/test_ros2_fastdds.py). It speaks to the node the way a ROS 2
// client on rmw_fastrtps_cpp does, so that the node's default request/reply mapping is checked
// against the real middleware library rather than against our own reading of it:
//
// * one service client per action service (send_goal, get_result, cancel_goal), each a reply
//   reader on `rr/<action>/_action/<service>Reply` created first and a request writer on
//   `rq/<action>/_action/<service>Request`, type names `control_msgs::action::dds_::…_` and
//   `action_msgs::srv::dds_::CancelGoal_…_`, QoS reliable, volatile, keep last 10;
// * every request is written with WriteParams whose related_sample_identity().writer_guid() is
//   the client's reply reader GUID (the sequence number left unknown); the write's
//   sample_identity() gives the request's sequence number;
// * a reply belongs to this client when its SampleInfo related_sample_identity names the reply
//   reader or the request writer of this client (rmw_fastrtps accepts both), and to the request
//   whose sequence number it carries. Every other reply is another client's ("foreign").
//
// Messages are encoded with eprosima::fastcdr::Cdr in hand-written TopicDataType classes (no
// fastddsgen, which needs Java): the Humble/Jazzy layout of control_msgs, as crates/ros2/src/msg.rs.
//
// DDS stays on 127.0.0.1: no builtin transports, one UDPv4 transport whitelisting 127.0.0.1, the
// initial peers 127.0.0.1.
//
// Usage: fastdds_peer DOMAIN_ID ACTION_NAME [LATE_READER_S]   (ACTION_NAME without the leading
// slash). With LATE_READER_S the send_goal reply reader is created disabled (its GUID is known, the
// node cannot see it yet) and enabled LATE_READER_S seconds after the first goal request is
// written ({"event":"reader_enabled"}): a server that answers before the requester's reply reader
// is matched loses that reply; one that waits (as rmw_fastrtps does) delivers it.
//
// Commands on stdin, one a line; events on stdout, one JSON object a line:
//
//   wait_matched SECONDS          every request writer and reply reader matched the node's
//                                 → {"event":"matched"} or {"event":"timeout"}
//   send_goal TAG UUID32 TOL T q1..q6 [T q1..q6 …]
//                                 a goal for joint_1…joint_6 (radians, T seconds from start;
//                                 TOL: goal tolerance per joint, 0 for none)
//   send_goal_on_match TAG …      the same, written the moment the send_goal request writer
//                                 matches the node's request reader (nothing else waited for)
//   get_result TAG UUID32
//   cancel TAG UUID32 SEC NANOSEC  (UUID32 all zeros and 0 0: cancel every goal)
//   quit
//
//   → {"event":"sent","tag":…,"service":…,"seq":N}
//   → {"event":"reply","tag":…,"service":…,"seq":N,"addressed_to":"reply_reader"|"request_writer",…}
//   → {"event":"foreign","service":…,"guid":…,"seq":N}   another client's reply
//   → {"event":"stray","service":…,"seq":N}              ours, but no request waits for it
//   → {"event":"error","what":…}

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/Exception.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/common/WriteParams.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>

namespace fdds = eprosima::fastdds::dds;
namespace frtps = eprosima::fastrtps::rtps;
using eprosima::fastcdr::Cdr;

// ------------------------------------------------------------------------------ messages

struct Time {
    int32_t sec = 0;
    uint32_t nanosec = 0;
    void serialize(Cdr& c) const { c << sec << nanosec; }
    void deserialize(Cdr& c) { c >> sec >> nanosec; }
};

using Duration = Time;  // builtin_interfaces/Duration has the same layout

struct Header {
    Time stamp;
    std::string frame_id;
    void serialize(Cdr& c) const { stamp.serialize(c); c << frame_id; }
};

struct JointTrajectoryPoint {
    std::vector<double> positions, velocities, accelerations, effort;
    Duration time_from_start;
    void serialize(Cdr& c) const {
        c << positions << velocities << accelerations << effort;
        time_from_start.serialize(c);
    }
};

struct JointTolerance {
    std::string name;
    double position = 0, velocity = 0, acceleration = 0;
    void serialize(Cdr& c) const { c << name << position << velocity << acceleration; }
};

using Uuid = std::array<uint8_t, 16>;

// control_msgs/action/FollowJointTrajectory goal (Humble/Jazzy): the multi-DOF trajectory and
// the component tolerances are always empty here.
struct Goal {
    Header header;
    std::vector<std::string> joint_names;
    std::vector<JointTrajectoryPoint> points;
    std::vector<JointTolerance> goal_tolerance;
    void serialize(Cdr& c) const {
        header.serialize(c);
        c << joint_names;
        c << static_cast<uint32_t>(points.size());
        for (const auto& p : points) p.serialize(c);
        // multi_dof_trajectory: header, joint_names, points
        Header().serialize(c);
        c << static_cast<uint32_t>(0) << static_cast<uint32_t>(0);
        c << static_cast<uint32_t>(0);  // path_tolerance
        c << static_cast<uint32_t>(0);  // component_path_tolerance
        c << static_cast<uint32_t>(goal_tolerance.size());
        for (const auto& t : goal_tolerance) t.serialize(c);
        c << static_cast<uint32_t>(0);  // component_goal_tolerance
        Duration().serialize(c);        // goal_time_tolerance
    }
};

struct SendGoalRequest {
    Uuid goal_id{};
    Goal goal;
    void serialize(Cdr& c) const { c << goal_id; goal.serialize(c); }
};

struct SendGoalResponse {
    bool accepted = false;
    Time stamp;
    void deserialize(Cdr& c) { c >> accepted; stamp.deserialize(c); }
    std::string json() const {
        std::ostringstream o;
        o << "\"accepted\":" << (accepted ? "true" : "false") << ",\"stamp_sec\":" << stamp.sec;
        return o.str();
    }
};

struct GetResultRequest {
    Uuid goal_id{};
    void serialize(Cdr& c) const { c << goal_id; }
};

std::string json_string(const std::string& s) {
    std::string out = "\"";
    for (unsigned char ch : s) {
        if (ch == '"' || ch == '\\') {
            out += '\\';
            out += static_cast<char>(ch);
        } else if (ch < 0x20) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\u%04x", ch);
            out += buf;
        } else {
            out += static_cast<char>(ch);
        }
    }
    return out + "\"";
}

std::string hex(const uint8_t* bytes, size_t n) {
    static const char* digits = "0123456789abcdef";
    std::string out;
    for (size_t i = 0; i < n; ++i) {
        out += digits[bytes[i] >> 4];
        out += digits[bytes[i] & 15];
    }
    return out;
}

struct GetResultResponse {
    int8_t status = 0;
    int32_t error_code = 0;
    std::string error_string;
    void deserialize(Cdr& c) { c >> status >> error_code >> error_string; }
    std::string json() const {
        std::ostringstream o;
        o << "\"status\":" << int(status) << ",\"error_code\":" << error_code
          << ",\"error_string\":" << json_string(error_string);
        return o.str();
    }
};

struct GoalInfo {
    Uuid goal_id{};
    Time stamp;
    void serialize(Cdr& c) const { c << goal_id; stamp.serialize(c); }
    void deserialize(Cdr& c) { c >> goal_id; stamp.deserialize(c); }
};

struct CancelGoalRequest {
    GoalInfo goal_info;
    void serialize(Cdr& c) const { goal_info.serialize(c); }
};

struct CancelGoalResponse {
    int8_t return_code = 0;
    std::vector<GoalInfo> goals_canceling;
    void deserialize(Cdr& c) {
        uint32_t n = 0;
        c >> return_code >> n;
        if (n > 1024) throw eprosima::fastcdr::exception::NotEnoughMemoryException("goals_canceling");
        goals_canceling.resize(n);
        for (auto& g : goals_canceling) g.deserialize(c);
    }
    std::string json() const {
        std::ostringstream o;
        o << "\"return_code\":" << int(return_code) << ",\"goals_canceling\":[";
        for (size_t i = 0; i < goals_canceling.size(); ++i) {
            o << (i ? "," : "") << "{\"goal_id\":\"" << hex(goals_canceling[i].goal_id.data(), 16)
              << "\",\"stamp_sec\":" << goals_canceling[i].stamp.sec << "}";
        }
        o << "]";
        return o.str();
    }
};

// ------------------------------------------------------------------------------ type support

// A TopicDataType for a message M: CDR with its encapsulation header, through fastcdr. Requests
// only serialise and replies only deserialise; the other direction reports failure.
template <class M, bool Request>
class CdrType : public fdds::TopicDataType {
public:
    explicit CdrType(const std::string& name) {
        setName(name.c_str());
        m_typeSize = 64 * 1024;
        m_isGetKeyDefined = false;
    }

    bool serialize(void* data, frtps::SerializedPayload_t* payload) override {
        if constexpr (Request) {
            eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(payload->data), payload->max_size);
            Cdr ser(buffer, Cdr::DEFAULT_ENDIAN, Cdr::DDS_CDR);
            payload->encapsulation = ser.endianness() == Cdr::BIG_ENDIANNESS ? CDR_BE : CDR_LE;
            try {
                ser.serialize_encapsulation();
                static_cast<M*>(data)->serialize(ser);
            } catch (const eprosima::fastcdr::exception::Exception&) {
                return false;
            }
            payload->length = static_cast<uint32_t>(ser.getSerializedDataLength());
            return true;
        } else {
            (void)data;
            (void)payload;
            return false;
        }
    }

    bool deserialize(frtps::SerializedPayload_t* payload, void* data) override {
        if constexpr (Request) {
            (void)payload;
            (void)data;
            return false;
        } else {
            eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(payload->data), payload->length);
            Cdr deser(buffer, Cdr::DEFAULT_ENDIAN, Cdr::DDS_CDR);
            try {
                deser.read_encapsulation();
                payload->encapsulation = deser.endianness() == Cdr::BIG_ENDIANNESS ? CDR_BE : CDR_LE;
                static_cast<M*>(data)->deserialize(deser);
            } catch (const eprosima::fastcdr::exception::Exception&) {
                return false;
            }
            return true;
        }
    }

    std::function<uint32_t()> getSerializedSizeProvider(void* data) override {
        return [data]() -> uint32_t {
            if constexpr (Request) {
                eprosima::fastcdr::FastBuffer buffer;  // grows as needed
                Cdr ser(buffer, Cdr::DEFAULT_ENDIAN, Cdr::DDS_CDR);
                ser.serialize_encapsulation();
                static_cast<M*>(data)->serialize(ser);
                return static_cast<uint32_t>(ser.getSerializedDataLength());
            } else {
                (void)data;
                return 64 * 1024;
            }
        };
    }

    void* createData() override { return new M(); }
    void deleteData(void* data) override { delete static_cast<M*>(data); }
    bool getKey(void*, frtps::InstanceHandle_t*, bool) override { return false; }
};

// ------------------------------------------------------------------------------ output

std::mutex out_mutex;

void emit(const std::string& json) {
    std::lock_guard<std::mutex> lock(out_mutex);
    std::cout << json << std::endl;
}

std::string guid_text(const frtps::GUID_t& g) {
    return hex(reinterpret_cast<const uint8_t*>(g.guidPrefix.value), 12) + "." +
           hex(reinterpret_cast<const uint8_t*>(g.entityId.value), 4);
}

int64_t seq_of(const frtps::SequenceNumber_t& s) {
    return (static_cast<int64_t>(s.high) << 32) | s.low;
}

// ------------------------------------------------------------------------------ service client

// One service client as rmw_fastrtps makes it: a reply reader, then a request writer.
class ServiceClient : public fdds::DataReaderListener {
public:
    ServiceClient(fdds::DomainParticipant* p, fdds::Publisher* pub, fdds::Subscriber* sub,
                  const std::string& service_name, const std::string& request_topic,
                  const std::string& reply_topic, fdds::TopicDataType* request_type,
                  fdds::TopicDataType* reply_type)
        : name_(service_name) {
        fdds::TypeSupport rq(request_type), rr(reply_type);
        rq.register_type(p);
        rr.register_type(p);
        fdds::Topic* reply = p->create_topic(reply_topic, rr.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
        fdds::Topic* request = p->create_topic(request_topic, rq.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
        if (reply == nullptr || request == nullptr) throw std::runtime_error("topic " + service_name);
        fdds::DataReaderQos rqos = fdds::DATAREADER_QOS_DEFAULT;
        rqos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
        rqos.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
        rqos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
        rqos.history().depth = 10;
        rqos.endpoint().history_memory_policy = frtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
        reader_ = sub->create_datareader(reply, rqos, this);
        fdds::DataWriterQos wqos = fdds::DATAWRITER_QOS_DEFAULT;
        wqos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
        wqos.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
        wqos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
        wqos.history().depth = 10;
        wqos.publish_mode().kind = fdds::SYNCHRONOUS_PUBLISH_MODE;
        wqos.endpoint().history_memory_policy = frtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
        writer_ = pub->create_datawriter(request, wqos);
        if (reader_ == nullptr || writer_ == nullptr) throw std::runtime_error("endpoints " + service_name);
        reader_guid_ = reader_->guid();
        writer_guid_ = writer_->guid();
    }

    bool writer_matched() const {
        fdds::PublicationMatchedStatus s;
        writer_->get_publication_matched_status(s);
        return s.current_count > 0;
    }

    bool reader_matched() const {
        fdds::SubscriptionMatchedStatus s;
        reader_->get_subscription_matched_status(s);
        return s.current_count > 0;
    }

    // Writes a request as rmw_fastrtps does and remembers it under `tag`.
    void send(const std::string& tag, void* request) {
        std::lock_guard<std::mutex> lock(mutex_);
        frtps::WriteParams params;
        params.related_sample_identity().writer_guid() = reader_guid_;
        if (!writer_->write(request, params)) {
            emit("{\"event\":\"error\",\"what\":\"write failed\",\"tag\":" + json_string(tag) + "}");
            return;
        }
        int64_t seq = seq_of(params.sample_identity().sequence_number());
        if (params.sample_identity().writer_guid() != writer_guid_) {
            emit("{\"event\":\"error\",\"what\":\"the write's sample identity names another writer\"}");
        }
        pending_[seq] = tag;
        std::ostringstream o;
        o << "{\"event\":\"sent\",\"tag\":" << json_string(tag) << ",\"service\":\"" << name_
          << "\",\"seq\":" << seq << "}";
        emit(o.str());
    }

    std::string identity_json() const {
        return "{\"reply_reader\":\"" + guid_text(reader_guid_) + "\",\"request_writer\":\"" +
               guid_text(writer_guid_) + "\"}";
    }

    const std::string& name() const { return name_; }

    // Enables the reply reader (created disabled by a subscriber that does not enable its
    // entities).
    void enable_reader() {
        if (reader_->enable() == ReturnCode_t::RETCODE_OK) {
            emit("{\"event\":\"reader_enabled\",\"service\":\"" + name_ + "\"}");
        } else {
            emit("{\"event\":\"error\",\"what\":\"the reply reader of " + name_ + " was not enabled\"}");
        }
    }

    virtual std::string take_one(fdds::DataReader* reader, fdds::SampleInfo& info, bool& taken) = 0;

    void on_data_available(fdds::DataReader* reader) override {
        for (;;) {
            fdds::SampleInfo info;
            bool taken = false;
            std::string body = take_one(reader, info, taken);
            if (!taken) return;
            if (!info.valid_data) continue;
            const frtps::SampleIdentity& related = info.related_sample_identity;
            int64_t seq = seq_of(related.sequence_number());
            std::ostringstream o;
            const char* to = related.writer_guid() == reader_guid_   ? "reply_reader"
                             : related.writer_guid() == writer_guid_ ? "request_writer"
                                                                     : nullptr;
            if (to == nullptr) {
                o << "{\"event\":\"foreign\",\"service\":\"" << name_ << "\",\"guid\":\""
                  << guid_text(related.writer_guid()) << "\",\"seq\":" << seq << "," << body << "}";
                emit(o.str());
                continue;
            }
            std::string tag;
            {
                std::lock_guard<std::mutex> lock(mutex_);
                auto it = pending_.find(seq);
                if (it != pending_.end()) {
                    tag = it->second;
                    pending_.erase(it);
                }
            }
            if (tag.empty()) {
                o << "{\"event\":\"stray\",\"service\":\"" << name_ << "\",\"addressed_to\":\"" << to
                  << "\",\"seq\":" << seq << "," << body << "}";
            } else {
                o << "{\"event\":\"reply\",\"tag\":" << json_string(tag) << ",\"service\":\"" << name_
                  << "\",\"addressed_to\":\"" << to << "\",\"seq\":" << seq << "," << body << "}";
            }
            emit(o.str());
        }
    }

protected:
    std::string name_;
    fdds::DataReader* reader_ = nullptr;
    fdds::DataWriter* writer_ = nullptr;
    frtps::GUID_t reader_guid_, writer_guid_;
    std::mutex mutex_;
    std::map<int64_t, std::string> pending_;
};

template <class Reply>
class TypedClient : public ServiceClient {
public:
    using ServiceClient::ServiceClient;
    std::string take_one(fdds::DataReader* reader, fdds::SampleInfo& info, bool& taken) override {
        Reply reply;
        taken = reader->take_next_sample(&reply, &info) == ReturnCode_t::RETCODE_OK;
        return taken ? reply.json() : std::string();
    }
};

// ------------------------------------------------------------------------------ commands

bool parse_uuid(const std::string& text, Uuid& out) {
    if (text.size() != 32) return false;
    for (size_t i = 0; i < 16; ++i) {
        unsigned v = 0;
        if (std::sscanf(text.c_str() + 2 * i, "%2x", &v) != 1) return false;
        out[i] = static_cast<uint8_t>(v);
    }
    return true;
}

Duration duration_of(double s) {
    Duration d;
    d.sec = static_cast<int32_t>(s);
    d.nanosec = static_cast<uint32_t>((s - d.sec) * 1e9 + 0.5);
    return d;
}

bool parse_goal(std::istringstream& in, SendGoalRequest& req) {
    std::string uuid;
    double tolerance = 0;
    if (!(in >> uuid >> tolerance) || !parse_uuid(uuid, req.goal_id)) return false;
    for (int j = 1; j <= 6; ++j) req.goal.joint_names.push_back("joint_" + std::to_string(j));
    double t = 0;
    while (in >> t) {
        JointTrajectoryPoint p;
        p.time_from_start = duration_of(t);
        for (int j = 0; j < 6; ++j) {
            double q = 0;
            if (!(in >> q)) return false;
            p.positions.push_back(q);
        }
        req.goal.points.push_back(p);
    }
    if (tolerance > 0) {
        for (const auto& n : req.goal.joint_names) req.goal.goal_tolerance.push_back({n, tolerance, 0, 0});
    }
    return !req.goal.points.empty();
}

int main(int argc, char** argv) {
    if (argc != 3 && argc != 4) {
        std::cerr << "usage: fastdds_peer DOMAIN_ID ACTION_NAME [LATE_READER_S] (e.g. 17 fs020n_controller/follow_joint_trajectory)\n";
        return 2;
    }
    const int domain = std::atoi(argv[1]);
    const std::string action = argv[2];
    const double late_reader_s = argc == 4 ? std::atof(argv[3]) : -1.0;

    fdds::DomainParticipantQos pqos = fdds::PARTICIPANT_QOS_DEFAULT;
    pqos.name("fs020n_fastdds_peer");
    pqos.transport().use_builtin_transports = false;
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interfaceWhiteList.push_back("127.0.0.1");
    pqos.transport().user_transports.push_back(udp);
    frtps::Locator_t peer;
    frtps::IPLocator::setIPv4(peer, 127, 0, 0, 1);
    pqos.wire_protocol().builtin.initialPeersList.push_back(peer);
    fdds::DomainParticipant* participant =
        fdds::DomainParticipantFactory::get_instance()->create_participant(domain, pqos);
    if (participant == nullptr) {
        std::cerr << "fastdds_peer: no participant on domain " << domain << "\n";
        return 1;
    }
    fdds::Publisher* pub = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    fdds::Subscriber* sub = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    fdds::SubscriberQos late_qos = fdds::SUBSCRIBER_QOS_DEFAULT;
    late_qos.entity_factory().autoenable_created_entities = false;
    fdds::Subscriber* late = late_reader_s >= 0 ? participant->create_subscriber(late_qos) : sub;

    const std::string a = action + "/_action/";
    const std::string fjt = "control_msgs::action::dds_::FollowJointTrajectory_";
    TypedClient<SendGoalResponse> send_goal(
        participant, pub, late, "send_goal", "rq/" + a + "send_goalRequest", "rr/" + a + "send_goalReply",
        new CdrType<SendGoalRequest, true>(fjt + "SendGoal_Request_"),
        new CdrType<SendGoalResponse, false>(fjt + "SendGoal_Response_"));
    TypedClient<GetResultResponse> get_result(
        participant, pub, sub, "get_result", "rq/" + a + "get_resultRequest", "rr/" + a + "get_resultReply",
        new CdrType<GetResultRequest, true>(fjt + "GetResult_Request_"),
        new CdrType<GetResultResponse, false>(fjt + "GetResult_Response_"));
    TypedClient<CancelGoalResponse> cancel_goal(
        participant, pub, sub, "cancel_goal", "rq/" + a + "cancel_goalRequest", "rr/" + a + "cancel_goalReply",
        new CdrType<CancelGoalRequest, true>("action_msgs::srv::dds_::CancelGoal_Request_"),
        new CdrType<CancelGoalResponse, false>("action_msgs::srv::dds_::CancelGoal_Response_"));
    ServiceClient* clients[] = {&send_goal, &get_result, &cancel_goal};

    emit("{\"event\":\"ready\",\"send_goal\":" + send_goal.identity_json() +
         ",\"get_result\":" + get_result.identity_json() + ",\"cancel_goal\":" + cancel_goal.identity_json() + "}");

    std::thread enabler;
    std::string line;
    while (std::getline(std::cin, line)) {
        std::istringstream in(line);
        std::string cmd, tag;
        in >> cmd;
        if (cmd.empty()) continue;
        if (cmd == "quit") break;
        if (cmd == "wait_matched") {
            double seconds = 0;
            in >> seconds;
            auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
            bool all = false;
            while (!(all = std::all_of(std::begin(clients), std::end(clients), [](ServiceClient* c) {
                         return c->writer_matched() && c->reader_matched();
                     })) &&
                   std::chrono::steady_clock::now() < deadline) {
                std::this_thread::sleep_for(std::chrono::milliseconds(10));
            }
            emit(all ? "{\"event\":\"matched\"}" : "{\"event\":\"timeout\"}");
            continue;
        }
        in >> tag;
        if (cmd == "send_goal" || cmd == "send_goal_on_match") {
            SendGoalRequest req;
            if (!parse_goal(in, req)) {
                emit("{\"event\":\"error\",\"what\":\"bad goal: " + cmd + " TAG UUID32 TOL T q1..q6 …\"}");
                continue;
            }
            if (cmd == "send_goal_on_match") {
                auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
                while (!send_goal.writer_matched() && std::chrono::steady_clock::now() < deadline) {
                    std::this_thread::sleep_for(std::chrono::microseconds(200));
                }
            }
            send_goal.send(tag, &req);
            if (late_reader_s >= 0 && !enabler.joinable()) {
                enabler = std::thread([&send_goal, late_reader_s]() {
                    std::this_thread::sleep_for(std::chrono::duration<double>(late_reader_s));
                    send_goal.enable_reader();
                });
            }
        } else if (cmd == "get_result") {
            GetResultRequest req;
            std::string uuid;
            if (!(in >> uuid) || !parse_uuid(uuid, req.goal_id)) {
                emit("{\"event\":\"error\",\"what\":\"bad get_result: get_result TAG UUID32\"}");
                continue;
            }
            get_result.send(tag, &req);
        } else if (cmd == "cancel") {
            CancelGoalRequest req;
            std::string uuid;
            if (!(in >> uuid >> req.goal_info.stamp.sec >> req.goal_info.stamp.nanosec) ||
                !parse_uuid(uuid, req.goal_info.goal_id)) {
                emit("{\"event\":\"error\",\"what\":\"bad cancel: cancel TAG UUID32 SEC NANOSEC\"}");
                continue;
            }
            cancel_goal.send(tag, &req);
        } else {
            emit("{\"event\":\"error\",\"what\":\"unknown command " + cmd + "\"}");
        }
    }
    if (enabler.joinable()) enabler.join();
    participant->delete_contained_entities();
    fdds::DomainParticipantFactory::get_instance()->delete_participant(participant);
    return 0;
}
