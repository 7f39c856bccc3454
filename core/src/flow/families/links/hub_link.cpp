// SPDX-License-Identifier: Apache-2.0
// A link to another hub (see hub_link.h, docs/hub-links.md).
#include "families/links/hub_link.h"

#include "connection.h"
#include "families/links/far_blobs.h"
#include "families/links/hub_route.h"
#include "hub.h"

#include <skrobot/runtime/log.h>
#include <skrobot/satellite/satellite.h>

#include <algorithm>

namespace skr::flow {

namespace {
constexpr const char* kLinkLog = "link";
constexpr Nanos kProbeEvery = 2 * kNsPerSec;
constexpr size_t kSamplesKept = 8;

}  // namespace

HubLink::HubLink(Hub& hub, HubLinkOptions options) : hub_(hub), opt_(std::move(options)) {
  user = "hub/" + opt_.name;  // never an account: nobody logs in as it
  client_name = "hub link " + opt_.name;
  if (!opt_.account.empty()) {  // what the far hub may do here over a shared connection
    if (hub_.session.auth != nullptr && hub_.session.auth->hasUser(opt_.account)) {
      access = hub_.session.auth->accessOf(opt_.account);
    } else {
      state_ = "bad account: the users file has no \"" + opt_.account + "\" (links[].account)";
    }
  }
  limits = access->limits().orElse(hub_.opt.user_limits);  // the far hub's requests, here
  limits.channels = opt_.max_channels;
  hub_.endpoints.add(*this);
  db_ = "_link." + opt_.name;
  since_ = utcNowText();
  if (auto db = hub_.databases.createOwnedDb(db_, *this); !db) {
    log::warn(kLinkLog, "HUB-LINK", db_ + ": " + db.error().message);
  }

  sat::SatelliteOptions so;
  if (auto address = Address::parse(opt_.address)) {
    so.connection.address = *address;
  } else {
    state_ = "bad address: " + address.error().message;
  }
  so.connection.user = opt_.user;
  so.connection.password = opt_.password;
  so.connection.client_name = "hub " + hub_.hub_name;
  so.connection.tls = opt_.tls;
  so.connection.max_frame_bytes = hub_.opt.max_frame_bytes;
  so.hub_name = hub_.hub_name;
  sat_ = std::make_unique<sat::Satellite>(hub_.loop, std::move(so));
  sat_->connected.connect(sat_.get(), [this] { opened(); });
  sat_->disconnected.connect(sat_.get(), [this](const std::string& why) { lost(why); });
  sat_->channelAdded.connect(sat_.get(), [this](const msg::ChannelInfo& i) { added(i); });
  sat_->channelRemoved.connect(sat_.get(), [this](const msg::ChannelInfo& i) { removed(i.id); });
  sat_->channelChanged.connect(sat_.get(), [this](const msg::ChannelInfo& i) { changed(i); });
  sat_->dataView.connect(sat_.get(),
                         [this](uint16_t id, std::string_view payload) { data(id, payload); });
  sat_->syncPulse.connect(sat_.get(), [this](const sat::SyncPulse& p) { farPulse(p); });
  sat_->linkWanted.connect(sat_.get(), [this](const std::string&) { offerAll(); });
  sat_->startPublish.connect(sat_.get(), [this](uint16_t id) { farDemand(id, true); });
  sat_->stopPublish.connect(sat_.get(), [this](uint16_t id) { farDemand(id, false); });
  sat_->serviceRequest.connect(sat_.get(), [this](const sat::Request& r) { farRequest(r); });
  sat_->blobChanged.connect(sat_.get(), [this](const sat::BlobChange& b) { farBlobChanged(b); });
  sat_->timeSample.connect(
      sat_.get(), [this](const sat::TimeSample& t) { timeSample(t.roundTripNs(), t.offsetNs()); });
  sat_->error.connect(sat_.get(), [this](const sat::FlowError& e) {
    if (e.command == uint8_t(Code::link_offer)) {  // another route has it there, or it may not
      std::erase_if(offers_, [&e](const auto& kv) { return kv.second.tag == e.tag; });
    } else if (e.command == uint8_t(Code::login) || e.command == uint8_t(Code::hub_link_hello)) {
      state_ = "refused: " + e.message;
      since_ = utcNowText();
      writeDb();
    }
  });
  writeDb();
}

HubLink::~HubLink() {
  sat_.reset();    // no handler of it runs any more
  blobs_.reset();  // nor a read of it (their answers find their connections by id)
  hub_.databases.removeOwnedDb(db_);
  hub_.removeEndpoint(*this);  // its channels go, everyone is told
}

void HubLink::start() {
  if (state_.starts_with("bad ")) {
    log::error(kLinkLog, "HUB-LINK", "hub " + opt_.name + ": " + state_);
    return;
  }
  log::info(kLinkLog, "HUB-LINK",
            "linking to hub " + opt_.name + " at " + opt_.address + " as " + opt_.user);
  sat_->start();
}

bool HubLink::congested() const {
  return !up_ || sat_->queuedBytes() > sat_->options().max_queued_bytes / 2;
}

std::string HubLink::describe() const {
  return "hub link " + opt_.name + " (" + opt_.address + ")";
}

void HubLink::opened() {
  if (sat_->linkedHub() != opt_.name) {
    log::error(kLinkLog, "HUB-LINK-NAME",
               "the hub at " + opt_.address + " is \"" + sat_->linkedHub() + "\", not \"" +
                   opt_.name + "\" as links[].name says; the link stays down");
    state_ = "wrong hub: " + sat_->linkedHub();
    since_ = utcNowText();
    writeDb();
    sat_->stop();
    return;
  }
  up_ = true;
  state_ = "up";
  since_ = utcNowText();
  samples_.clear();
  next_probe_ = 0;
  log::info(kLinkLog, "HUB-LINK-UP",
            "hub " + opt_.name + " linked at " + opt_.address + ", " +
                std::to_string(sat_->channels().size()) + " channels there");
  offerAgain();
  everySecond(monotonicNs());  // the first clock probe now
}

void HubLink::lost(const std::string& why) {
  if (up_) log::warn(kLinkLog, "HUB-LINK-DOWN", "hub " + opt_.name + ": " + why);
  if (up_ || state_ == "connecting") {
    state_ = "down: " + why;
    since_ = utcNowText();
  }
  up_ = false;
  dropAll();
  stopOffering();
  writeDb();
  // The channels this link took may come another way.
  for (const auto& other : hub_.links.all()) {
    if (other.get() != this) other->offerAgain();
  }
}

void HubLink::offerAgain() {
  if (shared_ != 0) {  // the far hub offers: ask it to
    if (Connection* c = hub_.connection(shared_)) hub_.links.askOffers(*c);
    return;
  }
  if (!up_) return;
  for (const msg::ChannelInfo& info : sat_->channels()) {
    // Ours over there are never shown here, and only their own EV_CHAN_ADDED answers an offer
    // (one withdrawn but not yet gone must not be taken for a new offer of the same name).
    if (info.owner_connection != sat_->login().connection_id) added(info);
  }
}

void HubLink::dropAll() {
  std::vector<uint16_t> ids;
  ids.reserve(by_local_.size());
  for (const auto& [local, r] : by_local_) ids.push_back(local);
  for (uint16_t local : ids) (void)hub_.channels.remove(*this, local);  // see onChannelRemoved
}

void HubLink::added(const msg::ChannelInfo& info) {
  if (!up_ || by_remote_.contains(info.id) || offered(info)) return;
  const auto kind = static_cast<ChannelKind>(info.kind);
  const std::string name = linkedName(info.name, opt_.name, hub_.hub_name);
  if (name.empty()) return;
  const std::vector<std::string> route = hubRoute(info.props, opt_.name);
  if (!routeAccepted(route, hub_.hub_name, hub_.opt.link_hops)) return;
  if (!hub_.links.takeRoute(name, route.size())) return;  // shown already, by a route as short
  if (by_local_.size() >= opt_.max_channels) {
    if (!limit_logged_) {
      log::warn(kLinkLog, "HUB-LINK-LIMIT",
                "hub " + opt_.name + ": more than links[].max_channels = " +
                    std::to_string(opt_.max_channels) + " channels; the rest are not shown here");
    }
    limit_logged_ = true;
    return;
  }
  const size_t dot = name.find('.');
  auto made = hub_.channels.createAs(*this, name.substr(0, dot), name.substr(dot + 1), kind,
                                     info.mime, routedProps(info.props, route), 0);
  if (!made) {
    log::warn(kLinkLog, "HUB-LINK-CHANNEL",
              "hub " + opt_.name + ": " + info.name + " not shown here: " + made.error().message);
    return;
  }
  const Channel* ch = *made;
  by_remote_[info.id] = ch->id;
  by_local_[ch->id] = Remote{info.id, info.name};
  // In-process subscribers waiting for this name (modules, replicas) came in createChannelAs,
  // before the lines above: onSubscribers could not tell which far channel it was.
  if (ch->subscriber_count > 0) sat_->subscribe(info.name);
}

void HubLink::removed(uint16_t remote_id) {
  if (auto o = offered_.find(remote_id); o != offered_.end()) {
    // One we offered: the far hub took a shorter route (it asks again when that one drops).
    (void)hub_.channels.unsubscribe(*this, o->second);
    offered_far_.erase(o->second);
    offered_.erase(o);
    return;
  }
  if (auto it = by_remote_.find(remote_id); it != by_remote_.end()) {
    (void)hub_.channels.remove(*this, it->second);  // see onChannelRemoved
  }
}

void HubLink::shownNoMore(const Channel& ch) {
  auto it = by_local_.find(ch.id);
  if (it == by_local_.end() || ch.owner != this || !sat_) return;
  // Its subscribers (or a source's targets) here went with it, without a last-subscriber event:
  // so goes our subscription over there, which the satellite would otherwise keep by name and
  // make again when the far channel comes back, with nobody behind it.
  if (ch.kind == ChannelKind::sync) {
    sat_->unfollow(it->second.remote_name);
  } else {
    sat_->unsubscribe(it->second.remote_name);
  }
  by_remote_.erase(it->second.remote_id);
  by_local_.erase(it);
}

void HubLink::changed(const msg::ChannelInfo& info) {
  auto it = by_remote_.find(info.id);
  if (it == by_remote_.end()) return;
  const Channel* ch = hub_.channels.find(it->second);
  const auto* props = info.props.asMap();
  if (ch == nullptr || props == nullptr) return;
  Variant::Map update = *props;
  update.erase("hub_route");  // the route stays ours
  (void)hub_.databases.replaceChannelProps(ch->name, update, {"hub_route"});
}

void HubLink::data(uint16_t remote_id, std::string_view payload) {
  auto it = by_remote_.find(remote_id);
  if (it == by_remote_.end()) return;
  ++traffic.messages_in;
  traffic.bytes_in += payload.size();
  (void)hub_.channels.publish(*this, it->second, payload);
}

void HubLink::onSubscribers(const Channel& ch, bool first) {
  auto it = by_local_.find(ch.id);
  if (it == by_local_.end()) return;
  if (first) {
    sat_->subscribe(it->second.remote_name);
  } else {
    sat_->unsubscribe(it->second.remote_name);
  }
}

void HubLink::onFollowers(const Channel& ch, bool first) {
  auto it = by_local_.find(ch.id);
  if (it == by_local_.end()) return;
  if (first) {
    sat_->follow(it->second.remote_name);
  } else {
    sat_->unfollow(it->second.remote_name);
  }
}

// A pulse of a far source that someone here follows: pulsed again here, as its owner, with the
// far source's time (CLOCK_MONOTONIC: comparable on one machine only, as for any source). The
// far hub hears that we are done when this returns; targets here that lag lose pulses here.
void HubLink::farPulse(const sat::SyncPulse& p) {
  auto it = by_remote_.find(p.chan_id);
  if (it == by_remote_.end()) return;
  ++traffic.messages_in;
  (void)hub_.sync.pulse(*this, it->second, p.source_time_ns);
}

void HubLink::onRequest(const Channel& ch, uint64_t request, const std::string& command,
                        const std::string& /*requester*/, const Variant& value) {
  const uint16_t local = ch.id;
  auto it = by_local_.find(local);
  const uint32_t timeout_ms = hub_.services.remainingMs(request, monotonicNs());
  if (it == by_local_.end() || timeout_ms == 0) return;
  ++requests_;
  auto sent = sat_->request(
      it->second.remote_id, command, value,
      [this, local, request](const sat::Response& r) {
        (void)hub_.services.respond(*this, local, request, r.value, r.error);
      },
      timeout_ms);
  if (!sent) {
    (void)hub_.services.respond(*this, local, request,
                                Variant("hub " + opt_.name + ": " + sent.error().message),
                                ErrorCode::owner_gone);
  }
}

void HubLink::farBlobChanged(const sat::BlobChange& b) {
  auto it = by_remote_.find(b.chan_id);
  if (it == by_remote_.end()) return;
  const Channel* ch = hub_.channels.find(it->second);
  if (ch == nullptr) return;
  ++traffic.messages_in;
  hub_.blobs.changed(ch->id, ch->hash, BlobEvent{uint8_t(b.change), b.path, b.size, b.version});
}

Result<uint16_t> HubLink::farBlobId(const Channel& ch) const {
  if (!up_) return makeError(Errc::io_error, "the link to hub " + opt_.name + " is down");
  auto it = by_local_.find(ch.id);
  if (it == by_local_.end() || !ch.far) {
    return makeError(Errc::not_found, "hub " + opt_.name + " shows no blob channel " + ch.name);
  }
  return it->second.remote_id;
}

FarBlobs& HubLink::farBlobs() {
  if (!blobs_) {  // the link's account, as its satellite (up: its address parsed)
    sat::ConnectOptions o = sat_->options().connection;
    o.client_name = "hub " + hub_.hub_name + " blob reads";
    blobs_ = std::make_unique<FarBlobs>(
        opt_.name, std::move(o),
        [&l = hub_.loop](std::function<void()> fn) { l.post(std::move(fn)); });
  }
  return *blobs_;
}

void HubLink::blobList(uint32_t reader, const Channel& ch, std::string dir,
                       std::function<void(Result<Variant>)> done) {
  auto far = farBlobId(ch);
  if (!far) return done(far.error());
  ++requests_;
  readers_.insert(reader);
  farBlobs().list(reader, *far, std::move(dir), std::move(done));
}

void HubLink::blobGet(uint32_t reader, const Channel& ch, std::string path, uint64_t version,
                      uint64_t offset, uint32_t max_bytes, size_t head_room,
                      std::function<void(Result<BlobStore::Read>)> done) {
  auto far = farBlobId(ch);
  if (!far) return done(far.error());
  ++requests_;
  readers_.insert(reader);
  farBlobs().get(reader, *far, std::move(path), version, offset, max_bytes, head_room,
                 std::move(done));
}

void HubLink::forgetReader(uint32_t reader) {
  if (readers_.erase(reader) != 0 && blobs_) blobs_->forget(reader);
}

bool HubLink::reaches(std::string_view hub) const {
  if (!up_) return false;
  if (hub == opt_.name) return true;
  return std::any_of(by_local_.begin(), by_local_.end(), [hub](const auto& kv) {
    const std::string& far = kv.second.remote_name;  // "<hub>/<user>.<name>" beyond the far hub
    return far.size() > hub.size() && far.starts_with(hub) && far[hub.size()] == '/';
  });
}

void HubLink::readDatabase(const std::string& db, msg::DbReadWhat what, const std::string& key,
                           std::function<void(Result<Variant>)> done) {
  ++requests_;
  auto sent = sat_->readDatabase(db, what, key, [name = opt_.name, done](const sat::Response& r) {
    if (r.ok()) return done(r.value);
    const std::string* why = r.value.asString();
    done(makeError(toErrc(r.error), "hub " + name + ": " + (why != nullptr ? *why : "")));
  });
  if (!sent) done(makeError(Errc::not_found, "hub " + opt_.name + ": " + sent.error().message));
}

void HubLink::onError(Code command, uint32_t, uint16_t chan_id, ErrorCode error,
                      const std::string& message) {
  log::warn(kLinkLog, "HUB-LINK-ERROR",
            describe() + ": " + std::string(codeName(static_cast<uint8_t>(command))) +
                " on channel " + std::to_string(chan_id) + ": " +
                std::string(errorCodeName(error)) + ": " + message);
}

void HubLink::everySecond(Nanos now) {
  if (redial_at_ != 0 && now >= redial_at_ && shared_ == 0) {
    redial_at_ = 0;
    sat_->start();
  }
  if (up_ && now >= next_probe_) {
    next_probe_ = now + kProbeEvery;
    (void)sat_->probeTime();
  }
  writeDb();
}

void HubLink::timeSample(int64_t round_trip_ns, int64_t offset_ns) {
  samples_.push_back({round_trip_ns, offset_ns});
  if (samples_.size() > kSamplesKept) samples_.erase(samples_.begin());
  writeDb();
}

void HubLink::writeDb() {
  PairDatabase* db = hub_.databases.store().find(db_);
  if (db == nullptr) return;
  const auto put = [db](const char* key, Variant v) { (void)db->set(key, std::move(v)); };
  const auto count = [](uint64_t n) { return Variant(static_cast<int64_t>(n)); };
  put("hub", Variant(opt_.name));
  put("address", Variant(opt_.address));
  put("user", Variant(opt_.user));
  put("state", Variant(state_));
  put("since", Variant(since_));
  const Endpoint* shared = shared_ != 0 ? hub_.endpoints.find(shared_) : nullptr;
  put("channels", count(shared != nullptr ? shared->owned.size() : by_local_.size()));
  put("shared", Variant(shared_ != 0));
  put("messages_in", count(traffic.messages_in));
  put("bytes_in", count(traffic.bytes_in));
  put("requests", count(requests_));
  put("dropped", count(sat_ ? sat_->stats().data_dropped : 0));
  if (!samples_.empty()) {
    const Sample best = *std::min_element(
        samples_.begin(), samples_.end(),
        [](const Sample& a, const Sample& b) { return a.round_trip_ns < b.round_trip_ns; });
    put("round_trip_us", Variant(static_cast<double>(best.round_trip_ns) / 1000.0));
    put("clock_offset_us", Variant(static_cast<double>(best.offset_ns) / 1000.0));
  }
}

}  // namespace skr::flow
