// Every message struct of messages.h, for code that must handle them all (the fuzz target, the
// round-trip tests): forEachMessage(f) calls f(M{}) once per message type.
#pragma once

#include <skrobot/flow/messages.h>

namespace skr::flow {

template <class F>
void forEachMessage(F&& f) {
  using namespace msg;
  f(Login{});
  f(LoginOk{});
  f(DbSelect{});
  f(DbCreate{});
  f(DbSave{});
  f(DbRemove{});
  f(VarGet{});
  f(VarSet{});
  f(VarDel{});
  f(Empty<Code::var_get_all>{});
  f(PollRegister{});
  f(PollFetch{});
  f(PollDeregister{});
  f(ServiceCall{});
  f(Ping{});
  f(ChanInfoByName{});
  f(Admin{});
  f(ReplyError{});
  f(ReplyValue{});
  f(PollData{});
  f(ChannelList{});
  f(ChannelInfoReply{});
  f(ChanAdd{});
  f(ChanRemove{});
  f(Subscribe{});
  f(Unsubscribe{});
  f(Publish{});
  f(ServiceRequest{});
  f(ServiceRequestTimed{});
  f(ServiceResponse{});
  f(DbSetCurrent{});
  f(DbCreateAsync{});
  f(DbRemoveAsync{});
  f(DbSaveAsync{});
  f(VarSetAsync{});
  f(VarDelAsync{});
  f(ChanSetProps{});
  f(EvDbChanged{});
  f(EvChanAdded{});
  f(EvChanRemoved{});
  f(EvChanHeader{});
  f(EvServiceRequest{});
  f(EvStartPublish{});
  f(EvStopPublish{});
  f(EvData{});
  f(EvServiceResponse{});
  f(EvError{});
  f(EvDropped{});
  f(DbSyncAsync{});
  f(EvDbSynced{});
  f(DbRead{});
  f(EvDbValue{});
  f(BlobList{});
  f(BlobGet{});
  f(BlobData{});
  f(BlobPut{});
  f(BlobPutOk{});
  f(BlobMkdir{});
  f(BlobRmdir{});
  f(BlobRemove{});
  f(BlobChunk{});
  f(BlobWritten{});
  f(BlobModify{});
  f(BlobAbort{});
  f(BlobCreate{});
  f(EvBlobChanged{});
  f(SyncPulse{});
  f(SyncFollow{});
  f(SyncUnfollow{});
  f(SyncDone{});
  f(EvSyncPulse{});
  f(PhysOffer{});
  f(PhysRequest{});
  f(PhysState{});
  f(PhysCount{});
  f(EvPhysGrant{});
  f(EvPhysPath{});
  f(EvPhysRevoke{});
  f(EvPhysRelay{});
  f(PhysSwitched{});
  f(EvPhysSwitch{});
  f(EvPhysMarker{});
  f(PhysReceived{});
  f(PhysFallback{});
  f(EvPhysResume{});
  f(PhysReplay{});
  f(HubLinkHello{});
  f(HubLinkHelloOk{});
  f(ReplicateChannel{});
  f(ReplicateStop{});
  f(TimeProbe{});
  f(EvTimeProbe{});
  f(LinkOffer{});
  f(EvLinkWanted{});
}

}  // namespace skr::flow
