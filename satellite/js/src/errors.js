// SPDX-License-Identifier: Apache-2.0
// Errors: FlowError carries the catalogue's error name as `code` (docs/flow-protocol.md, "Error
// codes"), with one subclass per name so that callers can use instanceof. ClosedError: the
// connection went away before an answer (skr::Errc::closed; never on the wire).
import { ERRORS } from './catalogue.js';

/** The wire value of each error name, from the catalogue. @type {Readonly<Record<string, number>>} */
export const ERROR_VALUES = Object.freeze(Object.fromEntries(ERRORS.map(([name, value]) => [name, value])));

/** A failure reported by the hub (or by the library on its behalf). */
export class FlowError extends Error {
  /**
   * @param {string} code the catalogue's error name ("not_found"), or "closed"
   * @param {string} message
   */
  constructor(code, message) {
    super(message);
    this.name = new.target.name;
    /** @type {string} */
    this.code = code;
  }
}

/** `protocol_error` */
export class ProtocolError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('protocol_error', message); }
}
/** `version_mismatch` */
export class VersionMismatchError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('version_mismatch', message); }
}
/** `auth_failed` */
export class AuthFailedError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('auth_failed', message); }
}
/** `not_logged_in` */
export class NotLoggedInError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('not_logged_in', message); }
}
/** `not_found` */
export class NotFoundError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('not_found', message); }
}
/** `already_exists` */
export class AlreadyExistsError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('already_exists', message); }
}
/** `permission_denied` */
export class PermissionDeniedError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('permission_denied', message); }
}
/** `invalid_argument` */
export class InvalidArgumentError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('invalid_argument', message); }
}
/** `timeout` */
export class TimeoutError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('timeout', message); }
}
/** `owner_gone` */
export class OwnerGoneError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('owner_gone', message); }
}
/** `overflow` */
export class OverflowError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('overflow', message); }
}
/** `unsupported` */
export class UnsupportedError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('unsupported', message); }
}
/** `limit_exceeded` */
export class LimitExceededError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('limit_exceeded', message); }
}
/** `io_error` */
export class IoError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('io_error', message); }
}
/** `internal` */
export class InternalError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('internal', message); }
}
/** The connection closed before the answer came (`closed`; never on the wire). */
export class ClosedError extends FlowError {
  /** @param {string} message */
  constructor(message) { super('closed', message); }
}

const BY_NAME = {
  protocol_error: ProtocolError,
  version_mismatch: VersionMismatchError,
  auth_failed: AuthFailedError,
  not_logged_in: NotLoggedInError,
  not_found: NotFoundError,
  already_exists: AlreadyExistsError,
  permission_denied: PermissionDeniedError,
  invalid_argument: InvalidArgumentError,
  timeout: TimeoutError,
  owner_gone: OwnerGoneError,
  overflow: OverflowError,
  unsupported: UnsupportedError,
  limit_exceeded: LimitExceededError,
  io_error: IoError,
  internal: InternalError,
};

/**
 * The error for a wire error value (u16) and the hub's message.
 * @param {number} value
 * @param {string} message
 * @returns {FlowError}
 */
export function errorFromWire(value, message) {
  const row = ERRORS.find(([, v]) => v === value);
  const name = row ? row[0] : 'internal';
  const C = BY_NAME[name];
  return C ? new C(message) : new FlowError(name, message);
}

/** The subclass of each error name (ok has none). */
export const ERROR_CLASSES = Object.freeze({ ...BY_NAME });
