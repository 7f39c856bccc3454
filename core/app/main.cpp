// Replaced by the full executable in the next commit.
int main() { return 0; }
