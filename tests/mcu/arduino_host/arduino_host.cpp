// SPDX-License-Identifier: Apache-2.0
// The host's Arduino (Arduino.h, WiFi.h, WiFiUdp.h of this folder): a clock, pins, the number
// formatting the core's WString needs, and WiFiUDP on a POSIX socket.
#include <Arduino.h>
#include <WiFi.h>
#include <WiFiUdp.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>
#include <thread>

namespace {
const auto kStart = std::chrono::steady_clock::now();
std::atomic<int> analog_reads{0};
std::atomic<int> analog_writes[32];
std::atomic<uint16_t> sketch_port{0}, real_port{0};
std::mt19937 rng(std::random_device{}());

char* format(long long v, bool is_unsigned, char* s, int radix) {
  char digits[72];
  int n = 0;
  unsigned long long u = is_unsigned || v >= 0 ? (unsigned long long)v : (unsigned long long)-v;
  do {
    const int d = (int)(u % (unsigned)radix);
    digits[n++] = (char)(d < 10 ? '0' + d : 'a' + d - 10);
    u /= (unsigned)radix;
  } while (u > 0);
  int at = 0;
  if (!is_unsigned && v < 0) s[at++] = '-';
  while (n > 0) s[at++] = digits[--n];
  s[at] = '\0';
  return s;
}
}  // namespace

HostWiFi WiFi;

extern "C" {
unsigned long millis(void) {
  return (unsigned long)std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::steady_clock::now() - kStart)
      .count();
}
unsigned long micros(void) {
  return (unsigned long)std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now() - kStart)
      .count();
}
void delay(unsigned long ms) {
  std::this_thread::sleep_for(std::chrono::milliseconds(ms));
}
void pinMode(uint8_t, uint8_t) {}
int analogRead(uint8_t) {
  return analog_reads++ & 0x3FF;
}
void analogWrite(uint8_t pin, int value) {
  analog_writes[pin & 31] = value;
}
char* itoa(int value, char* s, int radix) {
  return format(value, false, s, radix);
}
char* utoa(unsigned value, char* s, int radix) {
  return format(value, true, s, radix);
}
char* ltoa(long value, char* s, int radix) {
  return format(value, false, s, radix);
}
char* ultoa(unsigned long value, char* s, int radix) {
  return format((long long)value, true, s, radix);
}
char* dtostrf(double value, signed char width, unsigned char precision, char* s) {
  std::sprintf(s, "%*.*f", width, precision, value);
  return s;
}
}

long random(long howbig) {
  return howbig <= 0 ? 0 : (long)(rng() % (unsigned long)howbig);
}
long random(long howsmall, long howbig) {
  return howsmall >= howbig ? howsmall : howsmall + random(howbig - howsmall);
}
void randomSeed(unsigned long seed) {
  rng.seed((unsigned)seed);
}

int skr_host_last_analog_write(uint8_t pin) {
  return analog_writes[pin & 31];
}

void WiFiUDP::route(uint16_t from, uint16_t to) {
  sketch_port = from;
  real_port = to;
}

uint8_t WiFiUDP::begin(uint16_t) {
  stop();
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);  // port 0: tests run side by side
  if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return 0;
  return 1;
}

void WiFiUDP::stop() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

int WiFiUDP::beginPacket(IPAddress ip, uint16_t port) {
  out_ip_ = ip;
  out_port_ = port;
  out_len_ = 0;
  return fd_ >= 0 ? 1 : 0;
}

int WiFiUDP::beginPacket(const char*, uint16_t) {
  return 0;
}  // names are not resolved here

size_t WiFiUDP::write(uint8_t b) {
  return write(&b, 1);
}

size_t WiFiUDP::write(const uint8_t* buffer, size_t size) {
  if (size > sizeof out_ - out_len_) size = sizeof out_ - out_len_;
  std::memcpy(out_ + out_len_, buffer, size);
  out_len_ += size;
  return size;
}

int WiFiUDP::endPacket() {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  const uint8_t ip[4] = {out_ip_[0], out_ip_[1], out_ip_[2], out_ip_[3]};
  std::memcpy(&a.sin_addr.s_addr, ip, 4);
  a.sin_port = htons(out_port_ == sketch_port ? real_port.load() : out_port_);
  const ssize_t n =
      ::sendto(fd_, out_, out_len_, 0, reinterpret_cast<const sockaddr*>(&a), sizeof a);
  return n == (ssize_t)out_len_ ? 1 : 0;
}

int WiFiUDP::parsePacket() {
  sockaddr_in a{};
  socklen_t len = sizeof a;
  in_len_ = in_at_ = 0;
  const ssize_t n = ::recvfrom(fd_, in_, sizeof in_, 0, reinterpret_cast<sockaddr*>(&a), &len);
  if (n <= 0) return 0;
  const uint8_t* ip = reinterpret_cast<const uint8_t*>(&a.sin_addr.s_addr);
  remote_ip_ = IPAddress(ip[0], ip[1], ip[2], ip[3]);
  const uint16_t port = ntohs(a.sin_port);
  remote_port_ = port == real_port ? sketch_port.load() : port;
  in_len_ = (size_t)n;
  return (int)n;
}

int WiFiUDP::available() {
  return (int)(in_len_ - in_at_);
}

int WiFiUDP::read() {
  return in_at_ < in_len_ ? in_[in_at_++] : -1;
}

int WiFiUDP::read(unsigned char* buffer, size_t len) {
  if (len > in_len_ - in_at_) len = in_len_ - in_at_;
  std::memcpy(buffer, in_ + in_at_, len);
  in_at_ += len;
  return (int)len;
}

int WiFiUDP::peek() {
  return in_at_ < in_len_ ? in_[in_at_] : -1;
}
