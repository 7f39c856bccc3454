// SPDX-License-Identifier: Apache-2.0
// The FlowProtocol catalogue: one row per code, the one place a code's facts are written.
//
// Everything else derives from these rows: the Code enum, codeName, minorOf and the code's
// direction and connection (protocol.h), the classification of received frames and the dispatch
// of each code to its handler (dispatch.h), the list of message types (message_table.h), and,
// through tools/flow-catalogue, PySketch's code table (satellite/python/PySketch/flowcodes.py,
// generated) and the checks of docs/flow-protocol.md. A row's fields are its message struct's
// (messages.h, SKR_FLOW_FIELDS), so a layout is written once too. docs/internals.md, "Adding a
// code", lists what a new code touches.
//
// Columns:
//   code     the byte on the wire
//   name     the C++ name (Code::name); the wire name is its upper case (LOGIN)
//   minor    the protocol minor that introduced it (1.<minor>; 0 for 1.0)
//   dir      to_hub (a satellite or a linking hub sends it) or to_client (the hub sends it)
//   via      sync: on a synchronous connection (each request gets one reply, in order);
//            flow: on a flow; link_sync, link_flow: the same, between hubs only
//   family   who handles it in the hub (core/src/flow/families/): session, channels, databases,
//            services, blobs, sync, links, physical, admin
//   message  its body (a struct of messages.h)
//   reply    a synchronous request's REPLY_OK body (a struct of messages.h), else None
//
// Rows are in code order. A code's row never changes once its minor is released
// (docs/flow-protocol.md, "Minor versions"); a new code is a new row with the next minor.
#pragma once

// clang-format off
#define SKR_FLOW_CATALOGUE(X)                                                                     \
  /* synchronous requests (1.0 unless a minor is given) */                                       \
  X(0x01, login,                 0,  to_hub,    sync,      session,   Login,               LoginOk)             \
  X(0x02, db_select,             0,  to_hub,    sync,      databases, DbSelect,            Ack)                 \
  X(0x03, db_create,             0,  to_hub,    sync,      databases, DbCreate,            Ack)                 \
  X(0x04, db_save,               0,  to_hub,    sync,      databases, DbSave,              Ack)                 \
  X(0x05, db_remove,             0,  to_hub,    sync,      databases, DbRemove,            Ack)                 \
  X(0x06, var_get,               0,  to_hub,    sync,      databases, VarGet,              ReplyValue)          \
  X(0x07, var_set,               0,  to_hub,    sync,      databases, VarSet,              Ack)                 \
  X(0x08, var_del,               0,  to_hub,    sync,      databases, VarDel,              Ack)                 \
  X(0x09, var_get_all,           0,  to_hub,    sync,      databases, VarGetAll,           ReplyValue)          \
  X(0x0A, var_keys,              0,  to_hub,    sync,      databases, VarKeys,             ReplyValue)          \
  X(0x0B, chan_list,             0,  to_hub,    sync,      channels,  ChanList,            ChannelList)         \
  X(0x0C, poll_register,         0,  to_hub,    sync,      channels,  PollRegister,        Ack)                 \
  X(0x0D, poll_fetch,            0,  to_hub,    sync,      channels,  PollFetch,           PollData)            \
  X(0x0E, service_call,          0,  to_hub,    sync,      services,  ServiceCall,         ReplyValue)          \
  X(0x0F, go_async,              0,  to_hub,    sync,      session,   GoAsync,             Ack)                 \
  X(0x10, ping,                  0,  to_hub,    sync,      session,   Ping,                Pong)                \
  X(0x11, db_list,               0,  to_hub,    sync,      databases, DbList,              ReplyValue)          \
  X(0x12, chan_info,             0,  to_hub,    sync,      channels,  ChanInfoByName,      ChannelInfoReply)    \
  X(0x13, db_sync,               2,  to_hub,    sync,      databases, DbSync,              Ack)                 \
  X(0x14, admin,                 1,  to_hub,    sync,      admin,     Admin,               ReplyValue)          \
  X(0x15, poll_deregister,       4,  to_hub,    sync,      channels,  PollDeregister,      Ack)                 \
  X(0x16, session_limits,        12, to_hub,    sync,      session,   SessionLimits,       Ack)                 \
  /* commands on a flow */                                                                       \
  X(0x40, chan_add,              0,  to_hub,    flow,      channels,  ChanAdd,             None)                \
  X(0x41, chan_remove,           0,  to_hub,    flow,      channels,  ChanRemove,          None)                \
  X(0x42, subscribe,             0,  to_hub,    flow,      channels,  Subscribe,           None)                \
  X(0x43, unsubscribe,           0,  to_hub,    flow,      channels,  Unsubscribe,         None)                \
  X(0x44, publish,               0,  to_hub,    flow,      channels,  Publish,             None)                \
  X(0x45, service_request,       0,  to_hub,    flow,      services,  ServiceRequest,      None)                \
  X(0x46, service_response,      0,  to_hub,    flow,      services,  ServiceResponse,     None)                \
  X(0x47, db_set_current,        0,  to_hub,    flow,      databases, DbSetCurrent,        None)                \
  X(0x48, db_create_async,       0,  to_hub,    flow,      databases, DbCreateAsync,       None)                \
  X(0x49, db_remove_async,       0,  to_hub,    flow,      databases, DbRemoveAsync,       None)                \
  X(0x4A, db_save_async,         0,  to_hub,    flow,      databases, DbSaveAsync,         None)                \
  X(0x4B, var_set_async,         0,  to_hub,    flow,      databases, VarSetAsync,         None)                \
  X(0x4C, var_del_async,         0,  to_hub,    flow,      databases, VarDelAsync,         None)                \
  X(0x4D, chan_set_props,        0,  to_hub,    flow,      channels,  ChanSetProps,        None)                \
  X(0x4E, db_sync_async,         2,  to_hub,    flow,      databases, DbSyncAsync,         None)                \
  X(0x4F, service_request_timed, 4,  to_hub,    flow,      services,  ServiceRequestTimed, None)                \
  X(0x50, db_read,               6,  to_hub,    flow,      databases, DbRead,              None)                \
  X(0x51, subscribe_queue,       13, to_hub,    flow,      channels,  SubscribeQueue,      None)                \
  /* replies */                                                                                  \
  X(0x80, reply_ok,              0,  to_client, sync,      session,   Ack,                 None)                \
  X(0x81, reply_error,           0,  to_client, sync,      session,   ReplyError,          None)                \
  /* events on a flow */                                                                         \
  X(0x90, ev_db_changed,         0,  to_client, flow,      databases, EvDbChanged,         None)                \
  X(0x91, ev_chan_added,         0,  to_client, flow,      channels,  EvChanAdded,         None)                \
  X(0x92, ev_chan_removed,       0,  to_client, flow,      channels,  EvChanRemoved,       None)                \
  X(0x93, ev_chan_header,        0,  to_client, flow,      channels,  EvChanHeader,        None)                \
  X(0x94, ev_service_request,    0,  to_client, flow,      services,  EvServiceRequest,    None)                \
  X(0x95, ev_start_publish,      0,  to_client, flow,      channels,  EvStartPublish,      None)                \
  X(0x96, ev_stop_publish,       0,  to_client, flow,      channels,  EvStopPublish,       None)                \
  X(0x97, ev_data,               0,  to_client, flow,      channels,  EvData,              None)                \
  X(0x98, ev_service_response,   0,  to_client, flow,      services,  EvServiceResponse,   None)                \
  X(0x99, ev_error,              0,  to_client, flow,      session,   EvError,             None)                \
  X(0x9A, ev_dropped,            0,  to_client, flow,      channels,  EvDropped,           None)                \
  X(0x9B, ev_db_synced,          2,  to_client, flow,      databases, EvDbSynced,          None)                \
  X(0x9C, ev_db_value,           6,  to_client, flow,      databases, EvDbValue,           None)                \
  /* 1.3: blob channels */                                                                       \
  X(0xC0, blob_list,             3,  to_hub,    sync,      blobs,     BlobList,            ReplyValue)          \
  X(0xC1, blob_get,              3,  to_hub,    sync,      blobs,     BlobGet,             BlobData)            \
  X(0xC2, blob_put,              3,  to_hub,    sync,      blobs,     BlobPut,             BlobPutOk)           \
  X(0xC3, blob_mkdir,            3,  to_hub,    sync,      blobs,     BlobMkdir,           Ack)                 \
  X(0xC4, blob_rmdir,            3,  to_hub,    sync,      blobs,     BlobRmdir,           Ack)                 \
  X(0xC5, blob_remove,           3,  to_hub,    sync,      blobs,     BlobRemove,          Ack)                 \
  X(0xC6, blob_chunk,            3,  to_hub,    sync,      blobs,     BlobChunk,           BlobWritten)         \
  X(0xC7, blob_modify,           3,  to_hub,    sync,      blobs,     BlobModify,          BlobWritten)         \
  X(0xC8, blob_abort,            3,  to_hub,    sync,      blobs,     BlobAbort,           Ack)                 \
  X(0xC9, blob_create,           3,  to_hub,    sync,      blobs,     BlobCreate,          ChannelInfoReply)    \
  X(0xCF, ev_blob_changed,       3,  to_client, flow,      blobs,     EvBlobChanged,       None)                \
  /* 1.4: the sync pulse */                                                                      \
  X(0xD0, sync_pulse,            4,  to_hub,    flow,      sync,      SyncPulse,           None)                \
  X(0xD1, sync_follow,           4,  to_hub,    flow,      sync,      SyncFollow,          None)                \
  X(0xD2, sync_unfollow,         4,  to_hub,    flow,      sync,      SyncUnfollow,        None)                \
  X(0xD3, sync_done,             4,  to_hub,    flow,      sync,      SyncDone,            None)                \
  X(0xD8, ev_sync_pulse,         4,  to_client, flow,      sync,      EvSyncPulse,         None)                \
  /* 1.5, 1.6: replicas and hub links */                                                         \
  X(0xE0, replicate_channel,     5,  to_hub,    flow,      links,     ReplicateChannel,    None)                \
  X(0xE1, replicate_stop,        5,  to_hub,    flow,      links,     ReplicateStop,       None)                \
  X(0xE2, link_offer,            6,  to_hub,    link_flow, links,     LinkOffer,           None)                \
  X(0xE8, hub_link_hello,        5,  to_hub,    link_sync, links,     HubLinkHello,        HubLinkHelloOk)      \
  X(0xE9, time_probe,            5,  to_hub,    flow,      links,     TimeProbe,           None)                \
  X(0xEA, ev_time_probe,         5,  to_client, flow,      links,     EvTimeProbe,         None)                \
  X(0xEB, ev_link_wanted,        6,  to_client, link_flow, links,     EvLinkWanted,        None)                \
  /* 1.7 to 1.11: physical mode */                                                               \
  X(0xF0, phys_offer,            7,  to_hub,    flow,      physical,  PhysOffer,           None)                \
  X(0xF1, phys_request,          7,  to_hub,    flow,      physical,  PhysRequest,         None)                \
  X(0xF2, phys_state,            7,  to_hub,    flow,      physical,  PhysState,           None)                \
  X(0xF3, phys_count,            7,  to_hub,    flow,      physical,  PhysCount,           None)                \
  X(0xF4, phys_switched,         9,  to_hub,    flow,      physical,  PhysSwitched,        None)                \
  X(0xF5, phys_received,         10, to_hub,    flow,      physical,  PhysReceived,        None)                \
  X(0xF6, phys_fallback,         11, to_hub,    flow,      physical,  PhysFallback,        None)                \
  X(0xF7, phys_replay,           11, to_hub,    flow,      physical,  PhysReplay,          None)                \
  X(0xF8, ev_phys_grant,         7,  to_client, flow,      physical,  EvPhysGrant,         None)                \
  X(0xF9, ev_phys_path,          7,  to_client, flow,      physical,  EvPhysPath,          None)                \
  X(0xFA, ev_phys_revoke,        7,  to_client, flow,      physical,  EvPhysRevoke,        None)                \
  X(0xFB, ev_phys_relay,         7,  to_client, flow,      physical,  EvPhysRelay,         None)                \
  X(0xFC, ev_phys_switch,        9,  to_client, flow,      physical,  EvPhysSwitch,        None)                \
  X(0xFD, ev_phys_marker,        9,  to_client, flow,      physical,  EvPhysMarker,        None)                \
  X(0xFE, ev_phys_resume,        11, to_client, flow,      physical,  EvPhysResume,        None)

// The error codes (u16 on the wire). Each has the skr::Errc of the same name (flow::toErrc).
//   X(value, name, minor)
#define SKR_FLOW_ERRORS(X)        \
  X(0, ok, 0)                     \
  X(1, protocol_error, 0)         \
  X(2, version_mismatch, 0)       \
  X(3, auth_failed, 0)            \
  X(4, not_logged_in, 0)          \
  X(5, not_found, 0)              \
  X(6, already_exists, 0)         \
  X(7, permission_denied, 0)      \
  X(8, invalid_argument, 0)       \
  X(9, timeout, 0)                \
  X(10, owner_gone, 0)            \
  X(11, overflow, 0)              \
  X(12, unsupported, 0)           \
  X(13, limit_exceeded, 0)        \
  X(14, io_error, 0)              \
  X(15, internal, 0)

// Channel kinds (u8 in ChannelInfo and CHAN_ADD).   X(value, name, minor)
#define SKR_FLOW_CHANNEL_KINDS(X) \
  X(1, streaming, 0)              \
  X(2, service, 0)                \
  X(3, blob, 3)                   \
  X(4, sync, 4)

// The frames of a physical path's socket (path_framing.h), between an owner and a subscriber.
//   X(value, name)
#define SKR_FLOW_PATH_FRAMES(X) \
  X(1, hello)                   \
  X(2, welcome)                 \
  X(3, data)                    \
  X(4, bye)
// clang-format on
