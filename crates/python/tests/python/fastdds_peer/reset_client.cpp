// A std_srvs/Empty client of `stage_ros2`'s reset_positions on eProsima Fast DDS 2.x, speaking
// rmw_fastrtps's request/reply mapping: plain CDR payloads (no header in front), the request's
// identity carried out of band in the sample's inline QoS (related sample identity) and copied
// by the server onto its reply. test_ros2_fastdds.py compiles and runs it.
//
// Usage: reset_client DOMAIN MODE TIMEOUT_S
//   MODE "rmw_fastrtps": the request's related sample identity names this client's reply
//     reader (what rmw_fastrtps has sent since Humble; servers reply to that GUID);
//   MODE "plain": no related sample identity on the request (older rmw_fastrtps): the server
//     must answer with the request's own identity.
// Loopback only: UDPv4 on 127.0.0.1, builtin transports off, discovery by unicast initial
// peers (multicast on lo is off on Linux by default).
//
// Prints one "key=value ..." line per event for the test to read; exits 0 when a reply
// matched a request, 2 when no service was discovered, 3 when no reply matched in time.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/common/WriteParams.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;

namespace {

// std_srvs/Empty's request or response as ROS 2 declares it: one uint8 placeholder. `wire`
// keeps the serialized payload a received sample came in, to show what the server sent.
struct EmptyMessage
{
    uint8_t structure_needs_at_least_one_member = 0;
    std::vector<uint8_t> wire;
};

// The type support rmw_fastrtps would register: ROS 2's DDS type name, no key, the payload
// an encapsulation header and the one byte.
class EmptyType : public fdds::TopicDataType
{
public:
    explicit EmptyType(const char* name)
    {
        setName(name);
        // encapsulation (4) + the member (1), padded to 4
        m_typeSize = 8;
        m_isGetKeyDefined = false;
    }

    bool serialize(void* data, rtps::SerializedPayload_t* payload) override
    {
        auto* msg = static_cast<EmptyMessage*>(data);
        eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(payload->data),
                payload->max_size);
        eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN,
                eprosima::fastcdr::Cdr::DDS_CDR);
        try
        {
            cdr.serialize_encapsulation();
            cdr << msg->structure_needs_at_least_one_member;
        }
        catch (eprosima::fastcdr::exception::Exception&)
        {
            return false;
        }
        payload->encapsulation =
                cdr.endianness() == eprosima::fastcdr::Cdr::BIG_ENDIANNESS ? CDR_BE : CDR_LE;
        payload->length = static_cast<uint32_t>(cdr.getSerializedDataLength());
        return true;
    }

    bool deserialize(rtps::SerializedPayload_t* payload, void* data) override
    {
        auto* msg = static_cast<EmptyMessage*>(data);
        msg->wire.assign(payload->data, payload->data + payload->length);
        eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(payload->data),
                payload->length);
        eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN,
                eprosima::fastcdr::Cdr::DDS_CDR);
        try
        {
            cdr.read_encapsulation();
            cdr >> msg->structure_needs_at_least_one_member;
        }
        catch (eprosima::fastcdr::exception::Exception&)
        {
            return false;
        }
        return true;
    }

    std::function<uint32_t()> getSerializedSizeProvider(void*) override
    {
        return []() -> uint32_t { return 8; };
    }

    void* createData() override
    {
        return new EmptyMessage();
    }

    void deleteData(void* data) override
    {
        delete static_cast<EmptyMessage*>(data);
    }

    bool getKey(void*, rtps::InstanceHandle_t*, bool) override
    {
        return false;
    }
};

// Counts the remote endpoints matched, so that the request is written only once the
// service's reader and writer are known (a volatile reply to an unmatched reader is lost).
struct Matches : public fdds::DataWriterListener, public fdds::DataReaderListener
{
    std::atomic<int> readers{0};
    std::atomic<int> writers{0};

    void on_publication_matched(fdds::DataWriter*,
            const fdds::PublicationMatchedStatus& status) override
    {
        readers = status.current_count;
    }

    void on_subscription_matched(fdds::DataReader*,
            const fdds::SubscriptionMatchedStatus& status) override
    {
        writers = status.current_count;
    }
};

std::string hex(const uint8_t* bytes, size_t n)
{
    std::string out;
    char two[3];
    for (size_t i = 0; i < n; ++i)
    {
        std::snprintf(two, sizeof two, "%02x", bytes[i]);
        out += two;
    }
    return out;
}

std::string guid_hex(const rtps::GUID_t& guid)
{
    return hex(guid.guidPrefix.value, rtps::GuidPrefix_t::size) +
           hex(guid.entityId.value, rtps::EntityId_t::size);
}

int64_t seq_value(const rtps::SequenceNumber_t& seq)
{
    return (static_cast<int64_t>(seq.high) << 32) | seq.low;
}

std::string identity(const rtps::SampleIdentity& id)
{
    return "guid=" + guid_hex(id.writer_guid()) + " seq=" +
           std::to_string(seq_value(id.sequence_number()));
}

rtps::Locator_t loopback(uint32_t port)
{
    rtps::Locator_t locator;
    locator.kind = LOCATOR_KIND_UDPv4;
    eprosima::fastrtps::rtps::IPLocator::setIPv4(locator, 127, 0, 0, 1);
    locator.port = port;
    return locator;
}

}  // namespace

int main(int argc, char** argv)
{
    if (argc != 4)
    {
        std::fprintf(stderr, "usage: %s DOMAIN rmw_fastrtps|plain TIMEOUT_S\n", argv[0]);
        return 1;
    }
    const int domain = std::atoi(argv[1]);
    const std::string mode = argv[2];
    if (mode != "rmw_fastrtps" && mode != "plain")
    {
        std::fprintf(stderr, "unknown mode %s\n", argv[2]);
        return 1;
    }
    const auto timeout = std::chrono::duration<double>(std::atof(argv[3]));
    const auto deadline = std::chrono::steady_clock::now() + timeout;

    fdds::DomainParticipantQos pqos;
    pqos.name("fastdds_reset_client");
    pqos.transport().use_builtin_transports = false;
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interfaceWhiteList.emplace_back("127.0.0.1");
    // RustDDS takes the first free participant id of the domain; look at several
    udp->maxInitialPeersRange = 12;
    pqos.transport().user_transports.push_back(udp);
    auto& builtin = pqos.wire_protocol().builtin;
    // port 0: Fast DDS fills in the well-known ports of its participant id
    builtin.initialPeersList.push_back(loopback(0));
    builtin.metatrafficUnicastLocatorList.push_back(loopback(0));
    pqos.wire_protocol().default_unicast_locator_list.push_back(loopback(0));

    auto* factory = fdds::DomainParticipantFactory::get_instance();
    fdds::DomainParticipant* participant = factory->create_participant(domain, pqos);
    if (participant == nullptr)
    {
        std::printf("error=participant\n");
        return 1;
    }

    fdds::TypeSupport request_type(new EmptyType("std_srvs::srv::dds_::Empty_Request_"));
    fdds::TypeSupport reply_type(new EmptyType("std_srvs::srv::dds_::Empty_Response_"));
    request_type.register_type(participant);
    reply_type.register_type(participant);
    fdds::Topic* request_topic = participant->create_topic("rq/reset_positionsRequest",
                    request_type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    fdds::Topic* reply_topic = participant->create_topic("rr/reset_positionsReply",
                    reply_type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);

    // rmw_qos_profile_services_default: reliable, volatile, keep last 10
    Matches matches;
    fdds::Publisher* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    fdds::DataWriterQos wqos = fdds::DATAWRITER_QOS_DEFAULT;
    wqos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    wqos.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
    wqos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
    wqos.history().depth = 10;
    fdds::DataWriter* writer = publisher->create_datawriter(request_topic, wqos, &matches);
    fdds::Subscriber* subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    fdds::DataReaderQos rqos = fdds::DATAREADER_QOS_DEFAULT;
    rqos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    rqos.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
    rqos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
    rqos.history().depth = 10;
    fdds::DataReader* reader = subscriber->create_datareader(reply_topic, rqos, &matches);
    if (writer == nullptr || reader == nullptr)
    {
        std::printf("error=endpoints\n");
        return 1;
    }
    std::printf("client writer=%s reader=%s\n", guid_hex(writer->guid()).c_str(),
            guid_hex(reader->guid()).c_str());
    std::fflush(stdout);

    while (matches.readers == 0 || matches.writers == 0)
    {
        if (std::chrono::steady_clock::now() > deadline)
        {
            std::printf("error=no service (request readers %d, reply writers %d)\n",
                    matches.readers.load(), matches.writers.load());
            return 2;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    // the service's side may learn of our reply reader a little after we learn of it
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    std::printf("matched request_readers=%d reply_writers=%d\n", matches.readers.load(),
            matches.writers.load());
    std::fflush(stdout);

    std::vector<rtps::SampleIdentity> sent;
    bool answered = false;
    auto quiet_until = deadline;
    auto resend_at = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() < (answered ? quiet_until : deadline))
    {
        if (!answered && std::chrono::steady_clock::now() >= resend_at)
        {
            EmptyMessage request;
            rtps::WriteParams params;
            if (mode == "rmw_fastrtps")
            {
                params.related_sample_identity().writer_guid(reader->guid());
            }
            if (!writer->write(&request, params))
            {
                std::printf("error=write\n");
                return 1;
            }
            sent.push_back(params.sample_identity());
            std::printf("request %s related_%s\n", identity(params.sample_identity()).c_str(),
                    identity(params.related_sample_identity()).c_str());
            std::fflush(stdout);
            resend_at = std::chrono::steady_clock::now() + std::chrono::seconds(2);
        }
        EmptyMessage reply;
        fdds::SampleInfo info;
        while (reader->take_next_sample(&reply, &info) == ReturnCode_t::RETCODE_OK)
        {
            if (!info.valid_data)
            {
                continue;
            }
            const rtps::SampleIdentity& related = info.related_sample_identity;
            // rmw_fastrtps's client takes a reply naming either of its endpoints and matches
            // it to a request by the sequence number
            bool ours = related.writer_guid() == writer->guid() ||
                    related.writer_guid() == reader->guid();
            bool known = false;
            for (const auto& s : sent)
            {
                known = known || s.sequence_number() == related.sequence_number();
            }
            std::printf("reply related_%s sample_%s payload=%s member=%u ours=%d matched=%d\n",
                    identity(related).c_str(), identity(info.sample_identity).c_str(),
                    hex(reply.wire.data(), reply.wire.size()).c_str(),
                    reply.structure_needs_at_least_one_member, ours ? 1 : 0,
                    ours && known ? 1 : 0);
            std::fflush(stdout);
            if (ours && known && !answered)
            {
                answered = true;
                // stay a moment to see whether a second reply follows
                quiet_until = std::chrono::steady_clock::now() + std::chrono::milliseconds(800);
            }
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }

    participant->delete_contained_entities();
    factory->delete_participant(participant);
    if (!answered)
    {
        std::printf("error=no matching reply\n");
        return 3;
    }
    return 0;
}
