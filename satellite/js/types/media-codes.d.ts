export const MESSAGE_ENCODING: "skrobot.media";
export const HEADER_BYTES: 32;
export const ENCODINGS: readonly (Readonly<{
    encoding: "jpeg";
    format: 1;
    video: true;
    bitsPerPixel: 0;
    evenSize: false;
    mime: "image/jpeg";
}> | Readonly<{
    encoding: "mono8";
    format: 2;
    video: true;
    bitsPerPixel: 8;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "s16le";
    format: 3;
    video: false;
    bitsPerPixel: 0;
    evenSize: false;
    mime: "audio/L16";
}> | Readonly<{
    encoding: "rgb8";
    format: 4;
    video: true;
    bitsPerPixel: 24;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "bgr8";
    format: 5;
    video: true;
    bitsPerPixel: 24;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "rgba8";
    format: 6;
    video: true;
    bitsPerPixel: 32;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "bgra8";
    format: 7;
    video: true;
    bitsPerPixel: 32;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "mono16";
    format: 8;
    video: true;
    bitsPerPixel: 16;
    evenSize: false;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "nv12";
    format: 9;
    video: true;
    bitsPerPixel: 12;
    evenSize: true;
    mime: "application/octet-stream";
}> | Readonly<{
    encoding: "i420";
    format: 10;
    video: true;
    bitsPerPixel: 12;
    evenSize: true;
    mime: "application/octet-stream";
}>)[];
export const TYPE_KEYS: Readonly<{
    messageEncoding: "message_encoding";
    schemaName: "schema_name";
    schemaEncoding: "schema_encoding";
    schema: "schema";
}>;
export const MESSAGE_ENCODINGS: readonly (Readonly<{
    name: "skrobot.media";
    schema: "none";
    schemaEncodings: readonly any[];
}> | Readonly<{
    name: "json";
    schema: "optional";
    schemaEncodings: readonly string[];
}> | Readonly<{
    name: "cdr";
    schema: "required";
    schemaEncodings: readonly string[];
}> | Readonly<{
    name: "protobuf";
    schema: "required";
    schemaEncodings: readonly string[];
}> | Readonly<{
    name: "flatbuffer";
    schema: "required";
    schemaEncodings: readonly string[];
}> | Readonly<{
    name: "cbor";
    schema: "none";
    schemaEncodings: readonly any[];
}>)[];
